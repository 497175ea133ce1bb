"""Shared pieces of the hostile-input tests: a deadline, a private cache and temp folder.

Every test here feeds fmionnx a file built to hurt (docs/security.md lists them). A protection
that breaks must fail its test, not hang the suite or eat the machine's memory: the deadline
fails a runaway test, and inputs that would allocate gigabytes without their limit are read in
a child process with a capped address space (:func:`run_capped`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

import pytest

#: Seconds any test here may take; with the protections each takes a few at most.
DEADLINE = 120
#: Address space of a child reading a hostile file: enough for Python, lxml, fmpy and onnx,
#: far below what an unchecked 10^9-element declaration takes.
CAPPED_BYTES = 3 * 1024**3


@pytest.fixture(autouse=True)
def deadline() -> Iterator[None]:
    """Fail (instead of hanging the suite) when a protection broke and an input runs away."""

    def expired(signum: int, frame: FrameType | None) -> None:
        pytest.fail(f"took more than {DEADLINE} s: a protection no longer holds")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(DEADLINE)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(autouse=True)
def _private_places(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Archives unpack into this test's cache, never the user's."""
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))


def run_capped(code: str, *, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a fresh interpreter limited to :data:`CAPPED_BYTES` of memory."""
    prologue = (
        "import resource\n"
        f"resource.setrlimit(resource.RLIMIT_AS, ({CAPPED_BYTES}, {CAPPED_BYTES}))\n"
    )
    environment = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", **(env or {})}
    return subprocess.run(
        [sys.executable, "-c", prologue + textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=DEADLINE - 10,
        check=False,
        env=environment,
        cwd=Path(__file__).resolve().parents[2],
    )
