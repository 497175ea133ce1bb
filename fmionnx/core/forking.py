"""Helper processes forked from the command's process instead of started as new interpreters.

A new interpreter for a helper (the isolated models' zygote, the plot worker) imports the
interpreter's start, numpy and fmionnx's modules again: about a third of a second of CPU on
the 2-core machine, at the moment the command loads its models and both cores are busy. A
fork has all of it already.

Only the process of a ``fmionnx run`` command forks its run's helpers
(:func:`allow_forked_helpers`; a study's worker forks its zygote too, as it starts:
:mod:`fmionnx.backends.sweep.workerboot`), and only while it has one thread (another thread
may hold a lock the copy then waits on for ever): a program that calls fmionnx has memory,
descriptors, signal handlers and limits of its own that its helpers should not inherit, and
starts them as new interpreters as before. The command loads numpy with one BLAS thread for
that (:func:`load_numpy_with_one_blas_thread`). A copy keeps none of this process's
descriptors but those it is given (:func:`close_all_but`), writes nothing this process had
buffered, and never returns into the caller's code: it ends with ``os._exit``.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

#: The variable that sets how many threads numpy's BLAS (OpenBLAS) starts when it loads.
BLAS_THREADS = "OPENBLAS_NUM_THREADS"
#: A helper's environment besides its parent's, whether started or forked: numpy's BLAS and
#: OpenMP start no threads, so that a helper stays single-threaded (the zygote forks
#: children that enter namespaces, which only a single-threaded process may) and does not
#: compete with the run for cores.
HELPER_ENVIRONMENT = {BLAS_THREADS: "1", "OMP_NUM_THREADS": "1"}

_allowed = [False]


def allow_forked_helpers() -> None:
    """Let this process fork its helpers: it is a ``fmionnx run`` command and nothing else."""
    _allowed[0] = True


def load_numpy_with_one_blas_thread() -> None:
    """Load numpy with one BLAS thread, unless the environment names a number or numpy is
    loaded already.

    OpenBLAS starts a thread per core when it loads, and a process with threads is not
    forked. Nothing fmionnx runs multiplies large matrices in numpy (the models are FMUs,
    ONNX sessions with threads of their own, MuJoCo). The variable is set only while numpy
    loads: the processes the command starts (isolated models, a study's workers, ROS 2
    nodes) get the environment the command was given."""
    if BLAS_THREADS in os.environ or "numpy" in sys.modules:
        return
    os.environ[BLAS_THREADS] = "1"
    try:
        import numpy  # noqa: F401 - loaded now, with the variable set
    finally:
        del os.environ[BLAS_THREADS]


def threads() -> int:
    """Threads of this process, every one (Python's and native libraries' alike); 0 when
    ``/proc`` cannot tell."""
    try:
        return sum(1 for _ in Path("/proc/self/task").iterdir())
    except OSError:
        return 0


def single_threaded() -> bool:
    """Whether this process can be forked safely: it has one thread."""
    return hasattr(os, "fork") and threads() == 1


def may_fork_helpers() -> bool:
    """Whether this process forks its helpers now: it is allowed to and has one thread."""
    return _allowed[0] and single_threaded()


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


#: The signals that stop a run (:mod:`fmionnx.runtime.stopping`), held across a fork.
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}


@contextlib.contextmanager
def forked_helper() -> Iterator[int]:
    """``os.fork`` for a helper: the block runs with 0 in the copy (which must end with
    ``os._exit`` inside it) and with the copy's pid here.

    Nothing buffered here is written again by the copy (:func:`flush_all` first). In the
    copy, Ctrl-C is ignored (the parent decides what it means), every other signal this
    process handles in Python is back at its default action as in a new interpreter, and
    Python's wake-up descriptor is unset (the parent's is closed there): the parent's
    handlers would raise its stop request in code that does not expect it. The stop signals
    are held from before the fork to the end of the parent's block, which records the copy;
    when the block or a stop held meanwhile raises, the copy is killed and reaped before
    the exception goes on, so that no helper is left that nobody knows of."""
    flush_all()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())  # as it is: restored on the way out
    pid = 0
    try:
        signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
        pid = os.fork()
        if pid == 0:
            _become_helper(mask)
            try:
                yield 0
            finally:
                os._exit(1)  # a block that did not end the copy: never back into the caller
        yield pid
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a stop held meanwhile raises here
    except BaseException:
        if pid > 0:
            _end(pid)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        raise


def _become_helper(mask: set[int | signal.Signals]) -> None:
    """In the copy: the signal handling of a helper, then ``mask`` again. A copy that cannot
    have it ends here rather than go on as a second run."""
    try:
        signal.set_wakeup_fd(-1)
        for signum in signal.valid_signals():
            with contextlib.suppress(OSError, ValueError):
                if callable(signal.getsignal(signum)):
                    signal.signal(signum, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    except BaseException:
        os._exit(1)


def _end(pid: int) -> None:
    """Kill and reap the copy ``pid``."""
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)


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
