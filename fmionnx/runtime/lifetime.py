"""A run ends with no process of its models left.

A model is native code: it can ``fork`` (500 times, say), its children can leave its process
group (``setsid``) and hand over to orphaned grandchildren. None of them may outlive the run,
and none may hold up fmionnx: a child that inherited a pipe keeps it open for as long as it
lives, so whoever waits for that pipe's end would wait for ever.

Linux gives an unprivileged process one reliable hold on all of them: a *child subreaper*
(``PR_SET_CHILD_SUBREAPER``, Linux 3.4) adopts every orphan among its descendants, instead of
``init``. So the process that hosts a model is a subreaper, and so is the process that started
it; whatever the model leaves is, at every moment, a descendant of one of the two:

- the model's own process (an isolated child, the guardian's child) ends every descendant
  before it exits (:func:`end_descendants`);
- when the model's process dies before it could (a crash, ``exit()``, a kill at the step
  timeout), its children are adopted by the process that started it (the zygote, the
  guardian), which ends what it adopted (:func:`end_adopted`) before it says that the model's
  process has ended.

Processes are ended with ``SIGKILL`` through a ``pidfd`` opened *before* the process is checked
to still be the one found (so a process id reused meanwhile is never signalled), in rounds
until none is left: a process that is being killed cannot fork, so a fork bomb runs dry.
Under ``--sandbox`` a model cannot start a process at all (see :mod:`.isolated.sandbox`).

Only the standard library is used: the zygote imports this module.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

_PR_SET_PDEATHSIG, _PR_SET_CHILD_SUBREAPER, _PR_GET_CHILD_SUBREAPER = 1, 36, 37
#: Seconds the rounds of killing may take before the rest is left (a process stuck in the
#: kernel, state D, cannot die until it leaves it; nothing else takes this long).
END_TIMEOUT = 10.0
#: Pause between two rounds, while killed processes are still dying.
_ROUND_PAUSE = 0.001


@dataclass(frozen=True, slots=True)
class Process:
    """One process as ``/proc/<pid>/stat`` shows it."""

    pid: int
    parent: int
    state: str
    #: Clock ticks after boot at which it started: with the pid, who it is.
    start: int


def _libc() -> ctypes.CDLL:
    return ctypes.CDLL(None, use_errno=True)


def die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (``PR_SET_PDEATHSIG``): a child
    that serves one process is no orphan after it. Nothing where Linux cannot."""
    with contextlib.suppress(OSError, AttributeError):
        _libc().prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)


def set_subreaper(on: bool) -> bool:
    """Make this process a child subreaper (or no longer one); False where Linux cannot."""
    try:
        return bool(_libc().prctl(_PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


def is_subreaper() -> bool:
    """Whether this process adopts its descendants' orphans."""
    flag = ctypes.c_int(0)
    try:
        if _libc().prctl(_PR_GET_CHILD_SUBREAPER, ctypes.byref(flag), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    return bool(flag.value)


def _stat(pid: int) -> Process | None:
    try:
        text = Path(f"/proc/{pid}/stat").read_bytes().decode("ascii", "replace")
    except OSError:
        return None
    # "pid (comm) state ppid ...": comm may hold spaces and parentheses; it ends at the last ')'
    fields = text[text.rfind(")") + 2 :].split()
    try:
        return Process(pid, int(fields[1]), fields[0], int(fields[19]))
    except (IndexError, ValueError):
        return None


def _listed_children(pid: int) -> list[int] | None:
    """The pids of ``pid``'s children from ``/proc/<pid>/task/*/children`` (each thread's
    own), or None where the kernel has no such file (built without ``CONFIG_PROC_CHILDREN``):
    reading them is a few system calls, a scan of every process costs milliseconds."""
    try:
        tasks = os.listdir(f"/proc/{pid}/task")  # noqa: PTH208 - names only, in a hot path
    except OSError:
        return []  # gone
    found: list[int] = []
    for task in tasks:
        try:
            text = Path(f"/proc/{pid}/task/{task}/children").read_bytes()
        except FileNotFoundError:
            if not Path(f"/proc/{pid}/task/{task}").exists():
                continue  # the thread ended meanwhile
            return None
        except OSError:
            continue
        found.extend(int(word) for word in text.split())
    return found


def _scanned_children(pid: int) -> list[int]:
    """The pids of ``pid``'s children, from a scan of every process."""
    found = []
    for name in os.listdir("/proc"):  # noqa: PTH208 - names only
        if name.isdigit():
            entry = _stat(int(name))
            if entry is not None and entry.parent == pid:
                found.append(entry.pid)
    return found


def children(pid: int) -> list[Process]:
    """The direct children of ``pid`` now."""
    pids = _listed_children(pid)
    if pids is None:
        pids = _scanned_children(pid)
    return [entry for child in pids if (entry := _stat(child)) is not None and entry.parent == pid]


def process(pid: int) -> Process | None:
    """The process ``pid`` now, or None when there is none."""
    return _stat(pid)


def _subtrees(roots: Iterable[Process]) -> list[Process]:
    """``roots`` and all their descendants now, parents first."""
    found: list[Process] = []
    pending = list(roots)
    while pending:
        entry = pending.pop()
        found.append(entry)
        pending.extend(children(entry.pid))
    return found


def _kill(entry: Process) -> None:
    """SIGKILL ``entry`` if the process at its pid is still it (race-free with a pidfd)."""
    pidfd = -1
    with contextlib.suppress(OSError, AttributeError):
        pidfd = os.pidfd_open(entry.pid)
    try:
        now = _stat(entry.pid)
        if now is None or now.start != entry.start:
            return  # gone, or the pid now names another process
        with contextlib.suppress(ProcessLookupError, PermissionError):
            if pidfd >= 0:
                signal.pidfd_send_signal(pidfd, signal.SIGKILL)
            else:  # Linux < 5.3: the window between the check and the kill is tiny
                os.kill(entry.pid, signal.SIGKILL)
    finally:
        if pidfd >= 0:
            os.close(pidfd)


def _reap(pids: Iterable[int]) -> None:
    """Collect those of ``pids`` that are this process's children and have ended."""
    for pid in pids:
        with contextlib.suppress(ChildProcessError, OSError):
            os.waitpid(pid, os.WNOHANG)


def _end(pick: Callable[[], list[Process]], timeout: float) -> int:
    """Kill what ``pick`` chooses, round after round, until it chooses nothing (or
    ``timeout`` passed); returns how many processes were killed."""
    me = os.getpid()
    killed: set[tuple[int, int]] = set()
    deadline = time.monotonic() + timeout
    while True:
        chosen = pick()
        if not chosen:
            return len(killed)
        for entry in chosen:
            if entry.state != "Z":
                _kill(entry)
                killed.add((entry.pid, entry.start))
        _reap(entry.pid for entry in chosen if entry.parent == me)
        if time.monotonic() > deadline:
            return len(killed)
        time.sleep(_ROUND_PAUSE)


def end_descendants(timeout: float = END_TIMEOUT) -> int:
    """Kill every descendant of this process; returns how many there were.

    For the process that hosts a model, on its way out: nothing it started may stay.
    """
    me = os.getpid()
    return _end(lambda: _subtrees(children(me)), timeout)


def end_adopted(spare: Iterable[int], timeout: float = END_TIMEOUT, *, since: int = 0) -> int:
    """Kill this process's children other than ``spare`` (and their descendants).

    For a subreaper whose model process died: its orphans are now children of this one, and
    are ended before anyone is told the model's process has ended. ``since``: only children
    started at or after that tick (``Process.start``) count as adopted; older ones are not
    the model's.
    """
    me = os.getpid()
    kept = frozenset(spare)

    def pick() -> list[Process]:
        return _subtrees(c for c in children(me) if c.pid not in kept and c.start >= since)

    return _end(pick, timeout)


class Adoption:
    """This process adopts, for a while, the orphans of a child it forks, and ends them.

    Made just before the fork: from then on this process is a child subreaper (until
    :meth:`close`, unless it was one before). :meth:`end` kills its children that were not there
    before the fork and started no earlier than the forked child (what the forked child
    orphaned, and the child itself if it still runs), with their descendants.
    """

    def __init__(self) -> None:
        self._was = is_subreaper()
        self._made = self._was or set_subreaper(True)
        self._before = frozenset(c.pid for c in children(os.getpid()))
        self._since: int | None = None

    def forked(self, pid: int) -> None:
        """The child whose orphans are adopted is ``pid`` (just forked, not yet reaped)."""
        entry = process(pid)
        self._since = entry.start if entry is not None else 0

    def from_now(self) -> None:
        """What is adopted is whatever this process's children start from now on (models
        that run in this very process)."""
        ticks = os.sysconf("SC_CLK_TCK")
        self._since = int(time.clock_gettime(time.CLOCK_BOOTTIME) * ticks)

    def end(self, spare: Iterable[int] = ()) -> int:
        """Kill what the child left (and the child, if it runs), but ``spare``; returns how
        many."""
        if self._since is None:
            return 0
        return end_adopted(self._before | frozenset(spare), since=self._since)

    def close(self, spare: Iterable[int] = ()) -> None:
        """End what is left (but ``spare``), and stop adopting (unless this process did
        before)."""
        try:
            self.end(spare)
        finally:
            self._since = None
            if self._made and not self._was:
                set_subreaper(False)


@contextlib.contextmanager
def models_here() -> Iterator[None]:
    """The block runs models in this very process (``--isolate none``, ONNX, MuJoCo): what
    they start is adopted meanwhile and ended at its end, with every process this process
    started within the block -- but its zygote (kept for the next run).

    For the run pipeline, around an in-process run: ``with lifetime.models_here(): ...``.
    """
    adoption = Adoption()
    adoption.from_now()
    try:
        yield
    finally:
        from fmionnx.runtime.isolated.launcher import zygote_pid

        zygote = zygote_pid()
        adoption.close(() if zygote is None else (zygote,))
