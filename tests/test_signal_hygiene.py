"""tests/conftest.py gives each test the signal handlers the one before it found: a test that
leaves SIGINT ignored (a command run in-process that was stopped) would hand that on to every
program a later test starts (their Ctrl-C would pass unnoticed)."""

from __future__ import annotations

import signal
from typing import Any

#: SIGINT's handler as the first test found it (pytest may itself have been started with it
#: ignored: a background job of a shell without job control).
FOUND: list[Any] = []


def test_a_test_changes_sigint() -> None:
    found = signal.getsignal(signal.SIGINT)
    FOUND.append(found)
    signal.signal(signal.SIGINT, signal.SIG_DFL if found is signal.SIG_IGN else signal.SIG_IGN)


def test_the_next_test_finds_sigint_as_the_one_before_found_it() -> None:
    assert FOUND, "runs after the test above (one file: one worker, in order)"
    assert signal.getsignal(signal.SIGINT) is FOUND[0]
