"""tests/conftest.py gives each test the signal handlers the one before it found: a test that
leaves SIGINT ignored (a command run in-process that was stopped) would hand that on to every
program a later test starts (their Ctrl-C would pass unnoticed)."""

from __future__ import annotations

import signal
import subprocess
import sys


def test_a_test_leaves_sigint_ignored() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_the_next_test_and_what_it_starts_have_sigint_as_before() -> None:
    assert signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
    child = subprocess.run(
        [sys.executable, "-c", "import signal; print(signal.getsignal(signal.SIGINT))"],
        capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    assert "SIG_IGN" not in child.stdout  # Python's own Ctrl-C handler, as a rule
