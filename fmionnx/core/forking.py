"""Helper processes forked from this one instead of started as new interpreters.

A new interpreter for a helper (the isolated models' zygote, the plot worker) imports the
interpreter's start, numpy and fmionnx's modules again: about a third of a second of CPU on
the 2-core machine, at the moment the command loads its models and both cores are busy. A
fork has all of it already. Forking is safe only from a process with one thread (another
thread may hold a lock the copy then waits on for ever), so it is tried only then
(:func:`single_threaded`), and a caller falls back to a new interpreter otherwise. A copy
keeps none of this process's descriptors but those it is given (:func:`close_all_but`),
writes nothing this process had buffered (:func:`flush_all` before the fork), and never
returns into the caller's code: it ends with ``os._exit``.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path


def threads() -> int:
    """Threads of this process, every one (Python's and native libraries' alike)."""
    try:
        return sum(1 for _ in Path("/proc/self/task").iterdir())
    except OSError:
        return threading.active_count()


def single_threaded() -> bool:
    """Whether this process may be forked: it has one thread (numpy's BLAS counts: a
    command's process gives it one, :func:`fmionnx.cli.console`)."""
    return hasattr(os, "fork") and threads() == 1


def flush_all() -> None:
    """What a normal exit would flush before ``os._exit``: Python's streams, and C's (a model
    that ``printf``s to a pipe or file has its lines in the C library's buffer). Also what
    a process flushes before it forks, so that its copy does not write it a second time."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).fflush(None)


def close_all_but(keep: set[int]) -> None:
    """Close every descriptor of this process but the standard three and ``keep``."""
    low = 3
    for fd in sorted(keep):
        os.closerange(low, fd)
        low = fd + 1
    os.closerange(low, os.sysconf("SC_OPEN_MAX"))


#: The signals a helper handles otherwise than the process it is forked from.
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}


def fork_helper() -> int:
    """``os.fork`` for a helper: 0 in the copy, the copy's pid here.

    Nothing buffered here is written again by the copy (:func:`flush_all` first). In the
    copy, Ctrl-C is ignored (the parent decides what it means), SIGTERM and SIGHUP have
    their default actions as in a new interpreter, and Python's wake-up descriptor is unset
    (the parent's is closed there): the parent's handlers would raise the parent's stop
    request in code that does not expect it. The stop signals are held from before the fork
    until the copy has its own handling, so none lands in between."""
    flush_all()
    held = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    try:
        pid = os.fork()
        if pid == 0:
            signal.set_wakeup_fd(-1)
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            for signum in (signal.SIGTERM, signal.SIGHUP):
                signal.signal(signum, signal.SIG_DFL)
        return pid
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


class ForkedProcess:
    """A forked helper, as much of ``Popen`` as its owner uses (this process reaps it)."""

    def __init__(self, pid: int, what: str) -> None:
        self.pid = pid
        self._what = what
        self._ended = False

    def wait(self, timeout: float | None = None) -> int:
        """Wait for its exit; ``subprocess.TimeoutExpired`` after ``timeout`` seconds."""
        if self._ended:
            return 0
        deadline = math.inf if timeout is None else time.monotonic() + timeout
        while True:
            try:
                done, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:  # reaped by someone else
                done, status = self.pid, 0
            if done == self.pid:
                self._ended = True
                return os.waitstatus_to_exitcode(status)
            if time.monotonic() >= deadline:
                raise subprocess.TimeoutExpired(f"{self._what} {self.pid}", timeout or 0.0)
            time.sleep(0.01)

    def kill(self) -> None:
        """``SIGKILL`` it (nothing once it has been reaped)."""
        if not self._ended:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGKILL)
