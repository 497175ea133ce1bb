"""``--isolate guardian``: the whole run in one child process, guarded by this one.

Per-component isolation (:mod:`fmionnx.runtime.isolated`) costs a pipe round trip per step
of every isolated model: tens of microseconds on a busy machine, which dominates a run of
one fast FMU. The guardian buys back most of the crash safety for one ``fork``:

- the run (the master, every runner, checkpoints, the step-timeout watchdog) goes on in a
  forked child, unchanged; a completed, faulted or interrupted run's result comes back
  through a pipe and is written by this process as usual;
- the child records into shared memory (a memfd this process keeps open) and marks the
  work under way there: in the child (a fork that ends with the run) the master is handed
  :class:`SharedRecorder` and :class:`SharedMarker` through its injection points
  (:class:`~fmionnx.runtime.instruments.Instruments`), whose rows, row counts, time and work index live in the memfd (the
  loop's stores to the watchdog's marker land there). So when a model crashes, aborts or
  exits the process, this process still has every completed step and knows which component
  (or native group) was stepping at which time. It writes them, with a fault naming the
  component, like an isolated model's crash.

What it cannot say is the FMI function under way (the child's phases are not tracked, to
keep the loop's cost): per-component ``--isolate NAMES`` does, and confines with
``--sandbox``; a hang is caught by the watchdog in the child, as in-process.

Everything shared is written by the child and read by this process after the child has
ended (the progress cells excepted, which are only shown): no locking. The directory of
tracks is written to one of two slots and then switched to, so a crash while writing it
leaves the previous one. Linux only (``fork``, ``memfd_create``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import gc
import json
import logging
import mmap
import os
import pickle
import select
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.errors import RunError
from fmionnx.core.runner import RunnerFactory, fault
from fmionnx.runtime import lifetime
from fmionnx.runtime import recorder as recording
from fmionnx.runtime.instruments import Instruments
from fmionnx.runtime.published import Follower, Published, TailPiece
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus

#: The ``--isolate`` word that selects the guardian.
GUARDIAN = "guardian"
BACKEND_NAME = "inprocess"

#: Bytes of the control block at the start of the shared file: cells, then two directory slots.
CONTROL = 1 << 20  # sparse: pages cost only once written
# float64 cells of the control block
_T, _WORK, _DONE, _TOTAL, _SIM, _PROGRESS, _ABANDONED, _DIRECTORY, _PHASE, _PHASE_WHO = range(10)
#: How far the follower got from the front (rows; the guardian writes it): the child's share
#: of the follower's work, done once its run has ended, stops there (:func:`_tail`).
_FRONT = 10
#: A front beyond any run: the child formats nothing (more).
_NO_SHARE = float(1 << 60)
#: What the child is doing (the ``_PHASE`` cell; ``_PHASE_WHO``: the component's index in the
#: system): stored around each model's instantiate, setup and terminate calls, once per run.
#: The loop's steps are told apart by the marker's stores instead (no store more per step).
_PREPARING, _INSTANTIATE, _SETUP, _LOOP, _TERMINATE, _ENDED = range(6)
#: The phases a crash is blamed on, labelled as an isolated model's are.
_PHASE_LABELS = {
    _INSTANTIATE: "loading and instantiating the model",
    _SETUP: "initialization",
    _TERMINATE: "terminate",
}
#: Then, per lane of the parallel schedule (a worker thread stepping one component), the
#: step in flight there: (work index, t, n, place in the order); work index -1: none.
_LANES = 16
_LANE_SLOTS = 256  # lanes beyond these are not tracked (their crash is blamed on the loop's work)
_LANE_WORK, _LANE_T, _LANE_N, _LANE_PLACE = range(4)
_LANE_CELLS = 4
_CELLS = _LANES + _LANE_SLOTS * _LANE_CELLS
_SLOT = (CONTROL - _CELLS * 8) // 2
#: Seconds a stopped child gets to send its result (while nothing arrives) before it is
#: killed: a model that does not return from its step cannot see the stop request.
STOP_GRACE = 5.0
#: Bytes of the child's result message: the offset and length of the pickled result.
_RESULT_MESSAGE = 16

RunFunction = Callable[..., RunResult]
logger = logging.getLogger(__name__)


def available() -> str | None:
    """Why the guardian cannot run here, or None."""
    if not hasattr(os, "fork") or not hasattr(os, "memfd_create"):
        return "the guardian needs Linux (fork and memfd_create)"
    return None


class _Shared:
    """The memfd both processes map: control cells, the directory, then the tracks' rows."""

    def __init__(self) -> None:
        flags = os.MFD_CLOEXEC | getattr(os, "MFD_ALLOW_SEALING", 0)
        self.fd = os.memfd_create("fmionnx-guardian", flags)
        os.ftruncate(self.fd, CONTROL)
        #: Whether the file can never shrink: then this process may read it while the child
        #: runs (a mapping beyond a truncated end would kill this process with SIGBUS).
        self.sealed = False
        with contextlib.suppress(OSError, AttributeError):
            fcntl.fcntl(self.fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_SEAL)
            self.sealed = True
        self.size = CONTROL
        self.control = mmap.mmap(self.fd, CONTROL)
        self.cells = np.frombuffer(self.control, dtype=np.float64, count=_CELLS)
        self.cells[:] = 0.0
        self.cells[_WORK] = -1.0
        self.cells[_LANES + _LANE_WORK :: _LANE_CELLS] = -1.0

    # -- the child's side ----------------------------------------------------------------------

    def allocate(self, nbytes: int) -> tuple[mmap.mmap, int]:
        """A new region of ``nbytes`` at the end of the file (child only): (map, offset)."""
        offset = self.size
        pages = -(-max(nbytes, 8) // mmap.PAGESIZE) * mmap.PAGESIZE
        os.ftruncate(self.fd, offset + pages)
        self.size = offset + pages
        return mmap.mmap(self.fd, pages, offset=offset), offset

    def publish(self, directory: dict[str, Any]) -> bool:
        """Write the directory into the slot not in use, then switch to it (crash-safe);
        False when it does not fit (the one in use stays)."""
        data = json.dumps(directory).encode()
        if len(data) + 8 > _SLOT:  # half a MiB of column names: beyond any real system
            return False
        slot = 1 if int(self.cells[_DIRECTORY]) == 1 else 0  # the other one
        start = _CELLS * 8 + slot * _SLOT
        self.control[start : start + 8] = len(data).to_bytes(8, "little")
        self.control[start + 8 : start + 8 + len(data)] = data
        self.cells[_DIRECTORY] = slot + 1  # 0: none yet; 1 or 2: that slot
        return True

    # -- the guardian's side -------------------------------------------------------------------

    def directory(self) -> dict[str, Any] | None:
        return _directory_in(self.control)

    def count(self, offset: int, capacity: int) -> int:
        """The row count of the track region at ``offset`` (0 when outside the file)."""
        if not CONTROL <= offset <= os.fstat(self.fd).st_size - 8:
            return 0
        count = int.from_bytes(os.pread(self.fd, 8, offset), "little", signed=True)
        return max(0, min(count, capacity))

    def rows(self, offset: int, capacity: int, columns: int) -> tuple[int, np.ndarray]:
        """(count, rows) of a track region written by the child, copied out of the file."""
        size = os.fstat(self.fd).st_size
        nbytes = 8 + capacity * columns * 8
        if offset + nbytes > size:
            return 0, np.zeros((0, columns))
        with mmap.mmap(self.fd, size, prot=mmap.PROT_READ) as view:
            count = int.from_bytes(view[offset : offset + 8], "little", signed=True)
            count = max(0, min(count, capacity))
            rows = np.frombuffer(view, np.float64, count * columns, offset + 8).copy()
        return count, rows.reshape(count, columns)

    def close(self) -> None:
        """Unmap the control cells and close the descriptor; again, nothing: a second
        ``os.close`` of the number would close whatever file has it by then."""
        with contextlib.suppress(BufferError):
            self.control.close()
        fd, self.fd = self.fd, -1
        if fd >= 0:
            with contextlib.suppress(OSError):
                os.close(fd)


def _directory_in(control: mmap.mmap) -> dict[str, Any] | None:
    """The directory of tracks in the control region (None: none yet, torn or not a dict)."""
    chosen = int(np.frombuffer(control, np.float64, 1, _DIRECTORY * 8)[0])
    if chosen not in (1, 2):
        return None
    start = _CELLS * 8 + (chosen - 1) * _SLOT
    length = min(int.from_bytes(control[start : start + 8], "little"), _SLOT - 8)
    try:
        parsed = json.loads(control[start + 8 : start + 8 + length])
    except (ValueError, RecursionError):  # also read while the child runs: torn, or hostile
        return None
    return parsed if isinstance(parsed, dict) else None


class RowsShared:
    """Rows this process records into a sealed memfd, for another process to follow.

    The guardian's child records so for the guardian; an unguarded in-process run records so
    for its plot worker, which formats ``results.csv`` while the run goes on
    (:mod:`fmionnx.results.csvfollow`). The follower gets :attr:`fd` (inherited) and reads
    it with :func:`follow_rows`.
    """

    def __init__(self) -> None:
        self._shared = _Shared()
        self._registry = _SharedTracks(self._shared)

    @property
    def fd(self) -> int:
        return self._shared.fd

    @property
    def sealed(self) -> bool:
        """Whether a follower may map the file (it can never shrink under the mapping)."""
        return self._shared.sealed

    def recorder(self) -> SharedRecorder:
        """A recorder whose rows land in the file (the master's :class:`Instruments`)."""
        return SharedRecorder(self._registry)

    def close(self) -> None:
        """Close this process's descriptor (the recorder's mappings stay valid), and let go
        of the tracks: the registry and its tracks refer to each other, and a long-lived
        process (a notebook, a program running many systems) would keep the file's pages
        until a full garbage collection."""
        self._shared.close()
        with self._registry.lock:
            self._registry.tracks.clear()
            self._registry.recorders.clear()


def follow_rows(fd: int, steps: int) -> Published | None:
    """The rows another process records into the memfd ``fd`` (:class:`RowsShared`), as
    :class:`Published` for a run of ``steps`` base steps; None when the file is not sealed
    against shrinking (a mapping of it could then fault) or cannot be mapped."""
    try:
        seals = fcntl.fcntl(fd, fcntl.F_GET_SEALS)
        if not seals & fcntl.F_SEAL_SHRINK:
            return None
        control = mmap.mmap(fd, CONTROL, prot=mmap.PROT_READ)
    except (OSError, ValueError, AttributeError):
        return None
    return Published(fd, lambda: _directory_in(control), steps, sealed=True)


# -- the child: recording and marking into shared memory ---------------------------------------


class _SharedTracks:
    """The child's registry of tracks; republishes the directory when one is (re)allocated."""

    def __init__(self, shared: _Shared) -> None:
        self.shared = shared
        self.tracks: list[SharedTrack] = []
        self.recorders: list[SharedRecorder] = []
        self.works: list[str] = []
        #: Each work's place in the execution order (-1: unknown), parallel to ``works``.
        self.places: list[int] = []
        #: Each model's function that advances it (``fmi2DoStep``), by component name: a
        #: crash in the step of a component stepped alone is said to be in it.
        self.functions: dict[str, str] = {}
        #: Works are registered by the loop's thread and by lanes: one at a time.
        self.lock = threading.RLock()

    def publish(self) -> bool:
        """Publish the tracks' regions; False when the directory did not fit."""
        tracks = [
            {
                "offset": t.offset,
                "capacity": len(t.rows),
                "columns": t.columns,
                "period": t.period_steps,
                "place": t.place,
                "outputs": t.outputs,
            }
            for t in self.tracks
        ]
        order = [name for r in self.recorders for name in r.order]
        directory = {
            "tracks": tracks, "order": order, "works": self.works, "places": self.places,
            "functions": self.functions,
        }  # fmt: skip
        return self.shared.publish(directory)


#: The child's registry (set once in the forked child; empty in the guardian).
_REGISTRY: list[_SharedTracks] = []


class SharedTrack(recording.Track):
    """A track whose rows and count live in a shared file (the guardian's child, or a run
    followed by its plot worker: :class:`RowsShared`)."""

    offset: int = -1
    #: The registry of the file it lives in (set by :meth:`SharedRecorder.track`).
    registry: _SharedTracks | None = None
    _count: Any = None
    _count_cell: Any = None
    _block: mmap.mmap | None = None

    def allocate(self) -> None:
        """Reserve rows in shared memory (as :meth:`Track.allocate` does in private)."""
        self._place(min(self.capacity, recording.CHUNK_ROWS))

    def _grow(self) -> None:
        extra = min(max(len(self.rows), recording.CHUNK_ROWS), self.capacity - len(self.rows))
        self._place(len(self.rows) + max(extra, 1))

    def _place(self, rows: int) -> None:
        registry = self.registry
        assert registry is not None  # given by the recorder that made the track
        columns = len(self.columns)
        block, offset = registry.shared.allocate(8 + rows * columns * 8)
        count = memoryview(block)[:8].cast("q")  # a memoryview store: the cheapest there is
        new = np.frombuffer(block, np.float64, rows * columns, 8).reshape(rows, columns)
        kept = min(self.count, len(self.rows))
        if kept:
            new[:kept] = self.rows[:kept]
        count[0] = self.count
        left = self._block
        self.rows, self._count, self._block, self.offset = new, count, block, offset
        self._count_cell = np.frombuffer(block, np.int64, 1, 0)
        with registry.lock:  # a lane may be registering a work (and publishing) meanwhile
            if not any(track is self for track in registry.tracks):
                registry.tracks.append(self)
            published = registry.publish()
        if left is not None and published:  # else the directory in use still names it
            _release(left)

    def sample(self) -> None:
        """Append the current values as the next row; the count is published after it.

        :meth:`Track.sample`'s body, not a call to it: a ``super()`` call costs a third of
        the row again, in the loop of every step (it grows through ``_grow``, in shared
        memory).
        """
        count = self.count
        if count == len(self.rows):
            self._grow()
        row = self.rows[count]
        for view, a, b in self.views:
            if b - a == 1:
                row[a] = view[0]
            else:
                row[a:b] = view
        self.count = count = count + 1
        self._count[0] = count

    def count_address(self) -> int:
        """The count the guardian reads, in shared memory: the native loop publishes there."""
        return int(self._count_cell.ctypes.data)

    def truncate(self, count: int) -> None:
        """Keep at most ``count`` rows, here and in the count the guardian reads."""
        super().truncate(count)
        self._count[0] = self.count


def _release(region: mmap.mmap) -> None:
    """Give the pages of a region a grown track has left back to the system.

    The file only grows (it is sealed against shrinking), so without this a track's rows
    took twice their size in memory: every region it outgrew stayed in the file. Called
    after the directory names the new region: the guardian, after a crash, reads only what
    the directory names. A follower that read the old directory may still read the old
    region, as zeros: what it formats ahead is compared with the run's result bit for bit
    before use (:mod:`fmionnx.results.csvahead`), so such a piece is formatted again.
    """
    with contextlib.suppress(AttributeError, OSError, ValueError):  # not Linux: kept
        region.madvise(mmap.MADV_REMOVE)


class SharedRecorder(recording.Recorder):
    """A recorder whose tracks are :class:`SharedTrack` (the guardian's child, or a run that
    records for a follower: :class:`RowsShared`)."""

    def __init__(self, registry: _SharedTracks | None = None) -> None:
        """``registry``: the file's (:class:`RowsShared`); None: this process's, in the
        guardian's child."""
        super().__init__()
        self._registry = registry if registry is not None else _REGISTRY[0]
        self._registry.recorders.append(self)

    def track(self, period_steps: int, total_steps: int) -> recording.Track:
        track = SharedTrack(period_steps, total_steps // period_steps + 2)
        track.registry = self._registry
        self.tracks.append(track)
        return track


class SharedMarker:
    """The watchdog's marker, mirrored into the shared cells (child only).

    The loop stores the time and the work under way before each step, as for the watchdog;
    the stores also land in shared memory, where the guardian reads them after a crash. A
    step on a lane (a worker thread of the parallel schedule) is marked by the lane around
    the step, in a slot of its own: the loop may be busy elsewhere when it crashes.
    """

    __slots__ = ("_cells", "_index", "_slots", "_t_cell", "_work")

    def __init__(self, control: mmap.mmap) -> None:
        self._cells = memoryview(control)[: _CELLS * 8].cast("d")  # cheaper stores than numpy's
        self._t_cell = np.frombuffer(control, np.float64, 1, _T * 8)
        self._work: object = None
        self._index: dict[int, int] = {}
        #: id(work) -> first cell of its lane slot (one lane steps one work).
        self._slots: dict[int, int] = {}

    @property
    def t(self) -> float:
        return float(self._cells[_T])

    @t.setter
    def t(self, value: float) -> None:
        self._cells[_T] = value

    def t_address(self) -> int:
        """Where the native loop stores the time before each step (the cell read above)."""
        return int(self._t_cell.ctypes.data)

    @property
    def work(self) -> object:
        return self._work

    @work.setter
    def work(self, value: object) -> None:
        if value is self._work:  # one component stepping: the same work every step
            return
        self._work = value
        self._cells[_WORK] = self._work_index(value)

    def lane_started(self, job: Any) -> None:
        """Mark ``job`` (a :class:`~fmionnx.runtime.parallel.Job`) in flight on its lane."""
        key = id(job.work)
        base = self._slots.get(key)
        if base is None:
            base = self._lane_slot(key)
            if base < 0:
                return
        cells = self._cells
        cells[base + _LANE_T] = job.t
        cells[base + _LANE_N] = job.n
        cells[base + _LANE_PLACE] = job.index
        cells[base + _LANE_WORK] = self._work_index(job.work)  # last: the slot is whole

    def lane_ended(self, job: Any) -> None:
        """``job``'s step returned (or raised, which the loop settles): nothing in flight."""
        base = self._slots.get(id(job.work), -1)
        if base >= 0:
            self._cells[base + _LANE_WORK] = -1.0

    def _work_index(self, value: object) -> int:
        index = self._index.get(id(value))
        return index if index is not None else self._register(value)

    def _lane_slot(self, key: int) -> int:
        with _REGISTRY[0].lock:
            if key not in self._slots:
                slot = len(self._slots)
                self._slots[key] = _LANES + slot * _LANE_CELLS if slot < _LANE_SLOTS else -1
            return self._slots[key]

    def _register(self, value: object) -> int:
        registry = _REGISTRY[0]
        with registry.lock:
            index = self._index.get(id(value))
            if index is not None:
                return index
            index = len(registry.works)
            registry.works.append(str(getattr(value, "name", "")))
            registry.places.append(int(getattr(value, "place", -1)))
            registry.publish()
            self._index[id(value)] = index
        return index


def _die_with_parent() -> None:
    """Linux kills this child when the guardian dies (SIGKILL of the run leaves no orphan)."""
    from fmionnx.runtime.lifetime import die_with_parent

    die_with_parent()


def _fresh_streams() -> None:
    """New ``sys.stdout``/``sys.stderr`` on fds 1 and 2 for the forked child.

    The parent's may be wrappers (a live progress display redirects them through its
    console) whose locks another thread of the parent held at the fork: in the child that
    thread does not exist, and the first write would wait for it forever.
    """
    for fd, name in ((1, "stdout"), (2, "stderr")):
        old = getattr(sys, name, None)
        encoding = getattr(old, "encoding", None) or "utf-8"
        with contextlib.suppress(OSError, ValueError):
            stream = open(  # noqa: SIM115 - the child's stream for the rest of its life
                fd, "w", encoding=encoding, errors="backslashreplace", closefd=False,
                buffering=1,
            )  # fmt: skip
            setattr(sys, name, stream)
            setattr(sys, f"__{name}__", stream)


def _phased(method: Callable[..., Any], cells: Any, phase: int, then: int, who: int) -> Any:
    """``method``, storing ``phase`` (and ``who``) before the call and ``then`` after it."""

    def call(*args: Any, **kwargs: Any) -> Any:
        cells[_PHASE_WHO] = who
        cells[_PHASE] = phase
        outcome = method(*args, **kwargs)
        cells[_PHASE] = then
        return outcome

    return call


def _phased_runners(cells: Any, components: list[str]) -> Callable[[RunnerFactory], RunnerFactory]:
    """A wrapper of the master's runner factory (:class:`Instruments`): every runner made
    marks its phases in ``cells``.

    Runners of any factory (isolated components' proxies, a test's wrappers) are covered; a
    runner's ``instantiate``, ``setup`` and ``terminate`` become instance attributes that
    store the phase around the call. Only in the child, which ends with the run.
    """
    index = {name: i for i, name in enumerate(components)}
    registry = _REGISTRY[0]

    def wrap(make: RunnerFactory) -> RunnerFactory:
        def make_phased(component: Any, wiring: Any) -> Any:
            who = index.get(component.name, -1)
            cells[_PHASE_WHO], cells[_PHASE] = who, _INSTANTIATE  # making it may load it
            runner = make(component, wiring)
            cells[_PHASE] = _PREPARING
            phases = (
                ("instantiate", _INSTANTIATE, _PREPARING), ("setup", _SETUP, _LOOP),
                ("terminate", _TERMINATE, _ENDED),
            )  # fmt: skip
            for name, phase, then in phases:
                method = getattr(runner, name, None)
                if callable(method):
                    with contextlib.suppress(AttributeError, TypeError):  # slots: unmarked
                        setattr(runner, name, _phased(method, cells, phase, then, who))
            function = getattr(runner, "advance_function", None)
            if isinstance(function, str):
                with registry.lock:
                    registry.functions[component.name] = function
                    registry.publish()
            return runner

        return make_phased

    return wrap


def _child(
    run_fn: RunFunction,
    options: RunOptions,
    shared: _Shared,
    result_pipe: int,
    scratch: Path,
    components: list[str],
    follower: Follower | None = None,
) -> int:
    """Run in the forked child; returns its exit status (the result went down the pipe)."""
    _die_with_parent()
    _fresh_streams()
    os.environ["TMPDIR"] = str(scratch)
    tempfile.tempdir = str(scratch)
    _REGISTRY[:] = [_SharedTracks(shared)]
    cells = shared.cells
    # The master records and marks into shared memory and marks each model's phases there:
    # its injection points, not a patched master (this process, a fork, ends with the run).
    instruments = Instruments(
        recorder=SharedRecorder,
        marker=lambda: SharedMarker(shared.control),  # type: ignore[arg-type,return-value]
        runners=_phased_runners(cells, components),
        notices_stops=False,  # the guardian ends a child that a model keeps from a stop
    )

    def progress(done: int, total: int, sim: float) -> None:
        cells[_DONE], cells[_TOTAL], cells[_SIM] = done, total, sim
        cells[_PROGRESS] += 1

    abandon = options.abandon

    def abandoned(result: RunResult) -> None:
        if abandon is not None:
            abandon(result)
        cells[_ABANDONED] = 1.0  # only now: the results are written (else the guardian does)

    options = dataclasses.replace(
        options,
        progress=progress if options.progress is not None else None,
        abandon=abandoned,
        instruments=instruments,
    )
    result = run_fn(options=options)
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):  # the result goes out whole
        signal.signal(signum, signal.SIG_IGN)
    error = result.error
    if error is not None and type(error) is not RunError:  # a subclass may not unpickle
        plain = RunError(str(error), component=error.component, port=error.port, time=error.time)
        result = dataclasses.replace(result, error=plain)
    pieces = [] if follower is None else _tail(follower, result, shared)
    # The result goes into the shared file and only its place down the pipe: megabytes through
    # a pipe would cost a wake-up of each process per 64 KiB, slow on a loaded machine.
    data = pickle.dumps((result, pieces), protocol=pickle.HIGHEST_PROTOCOL)
    block, offset = shared.allocate(len(data))
    block[: len(data)] = data
    block.flush()
    os.write(result_pipe, offset.to_bytes(8, "little") + len(data).to_bytes(8, "little"))
    return 0


#: Where the child left a piece of the follower's work: (first row, rows, columns, offset of
#: its values in the shared file, length of its text, which follows the values).
_PieceAt = tuple[int, int, int, int, int]


def _tail(follower: Follower, result: RunResult, shared: _Shared) -> list[_PieceAt]:
    """The child's share of the follower's work, written into the shared file (nothing when
    it fails: it only saves the guardian time)."""
    cells = shared.cells
    placed: list[_PieceAt] = []
    try:
        for first, values, text in follower.tail(result, lambda: int(cells[_FRONT])):
            numbers = np.ascontiguousarray(values, dtype=np.float64)
            rows, columns = numbers.shape
            block, offset = shared.allocate(numbers.nbytes + len(text))
            with block:
                block[: numbers.nbytes] = numbers.tobytes()
                block[numbers.nbytes : numbers.nbytes + len(text)] = text
            placed.append((first, rows, columns, offset, len(text)))
    except Exception:
        logger.debug("guardian child: the follower's share failed", exc_info=True)
    return placed


def _adopt(follower: Follower, shared: _Shared, placed: object) -> None:
    """Hand the follower the pieces the child left in the shared file, each checked to lie
    inside it (the follower checks their values against the result before it uses them).
    The caller keeps the run's result whatever this raises."""
    if not isinstance(placed, list) or not placed:
        return
    size = os.fstat(shared.fd).st_size
    pieces: list[TailPiece] = []
    with mmap.mmap(shared.fd, size, prot=mmap.PROT_READ) as view:
        for entry in placed:
            if not (isinstance(entry, tuple) and len(entry) == 5):
                return
            if not all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in entry):
                return
            first, rows, columns, offset, length = entry
            nbytes = rows * columns * 8
            if offset < CONTROL or offset + nbytes + length > size:
                return
            values = np.frombuffer(view, np.float64, rows * columns, offset).copy()
            text = view[offset + nbytes : offset + nbytes + length]
            pieces.append((first, values.reshape(rows, columns), text))
    follower.adopt(pieces)


def run_guarded(
    system: CompiledSystem,
    run_fn: RunFunction,
    options: RunOptions,
    follower: Follower | None = None,
) -> RunResult:
    """``run_fn(options=options)`` in a forked child; a crash of the child is a fault here.

    ``follower`` puts the rows the child publishes to use while it runs (this process is
    idle meanwhile): ``results.csv`` formatted ahead, :mod:`fmionnx.results.csvahead`.
    """
    from fmionnx.core.scratch import make_scratch, remove_scratch
    from fmionnx.runtime.stopping import late_stop_text, stop_reason, stops_held

    shared = _Shared()
    published = None
    if follower is not None and shared.sealed:
        published = Published(shared.fd, shared.directory, system.run.steps, sealed=True)
    scratch = make_scratch("guardian")
    read_end, write_end = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    started = time.perf_counter()
    # Objects made so far are left out of the garbage collector's passes, in both processes:
    # a pass writes to every object it visits, which after the fork copies each page of the
    # heap once more (0.05 s of CPU for a lone FMU's run; the guardian formats results.csv
    # meanwhile, which runs the collector).
    gc.freeze()
    # The model's processes: the child adopts what they orphan while it lives and ends them
    # before it exits; this process adopts them when the child dies first, and ends them
    # once it has reaped the child (runtime/lifetime.py).
    adoption = lifetime.Adoption()
    try:
        pid = os.fork()
    except BaseException:
        adoption.close()
        gc.unfreeze()
        raise
    if pid == 0:  # the child: never returns into the caller
        code = 70
        try:
            lifetime.set_subreaper(True)  # not inherited through fork
            os.close(read_end)
            components = [c.name for c in system.components]
            sharing = follower if published is not None else None
            code = _child(run_fn, options, shared, write_end, scratch, components, sharing)
        except BaseException:
            with contextlib.suppress(Exception):
                traceback.print_exc()
        finally:
            with contextlib.suppress(Exception):
                sys.stdout.flush()
                sys.stderr.flush()
            with contextlib.suppress(BaseException):
                lifetime.end_descendants()
            os._exit(code)
    os.close(write_end)
    adoption.forked(pid)
    late: list[str] = []
    # Entered once the child is done, left last: a stop signal from then on cuts nothing off
    # (the child's result taken, its processes ended, the scratch removed).
    with contextlib.ExitStack() as after_child:
        try:
            following = None if published is None or follower is None else (follower, published)
            data, reason = _wait(pid, read_end, shared, options, stop_reason, following)
            late = after_child.enter_context(stops_held())
            status = _reap(pid)
            adoption.end()  # before the run is reported over: nothing of the model is left
            if shared.cells[_ABANDONED]:  # the watchdog in the child wrote the results
                # The process ends with status 1 as an abandoned in-process run's does, but
                # through SystemExit: the caller's progress display is taken down on the way
                # out (the terminal's cursor restored), and nothing is written twice.
                raise SystemExit(1)
            outcome = _unpickle(data, shared)
            if outcome is None:
                result = _salvage(system, shared, status, reason, time.perf_counter() - started)
            else:
                result, placed = outcome
                if follower is not None and published is not None:
                    try:
                        _adopt(follower, shared, placed)
                    except Exception:  # an optimisation: the results are formatted without it
                        logger.debug("guardian: the child's pieces were not taken", exc_info=True)
        finally:
            adoption.close()
            gc.unfreeze()
            if published is not None:
                published.close()
            os.close(read_end)
            shared.close()
            remove_scratch(scratch)
    if late:
        result.warnings.append(late_stop_text(late[0]))
    return result


def _wait(
    pid: int,
    pipe: int,
    shared: _Shared,
    options: RunOptions,
    stop_reason: Callable[[BaseException], str],
    following: tuple[Follower, Published] | None = None,
) -> tuple[bytes, str | None]:
    """Read the child's result until the pipe closes or the child ends; pass progress and
    stop signals on, and let the follower work while nothing arrives.

    The child's end is watched on its own (not only the pipe's): processes the model forked
    inherited the pipe and keep it open for as long as they live; they are ended once the
    child is reaped (:class:`~fmionnx.runtime.lifetime.Adoption`), never waited for.

    The child is killed when it stays silent for :data:`STOP_GRACE` seconds after it was
    asked to stop (stuck in a model) or after its result arrived (stuck on its way out: its
    result is whole and is used).

    The first stop signal is passed on to the child; later ones are not seen here (the
    CLI's ``stop_on_signals`` ignores them), so a child that does not stop is killed at
    the deadline, not earlier.
    """
    chunks: list[bytes] = []
    received = 0
    reason: str | None = None
    seen = 0.0
    cells = shared.cells
    deadline = float("inf")
    busy = False  # the follower found work last time: look at the pipe without waiting
    ended = _Ended(pid)
    try:
        while True:
            try:
                ready, _, _ = select.select(
                    [pipe, *ended.fds], [], [], 0.0 if busy else _tick(following)
                )
                if pipe in ready:
                    chunk = os.read(pipe, 1 << 20)
                    if not chunk:
                        break
                    chunks.append(chunk)
                    received += len(chunk)
                    if reason is not None or received >= _RESULT_MESSAGE:
                        deadline = time.monotonic() + STOP_GRACE
                if ended():  # what it wrote before it ended is in the pipe: take it, done
                    chunks.extend(_drain(pipe))
                    break
                if not ready and time.monotonic() > deadline:  # stopped or done, silent: stuck
                    deadline = float("inf")
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, signal.SIGKILL)
                if options.progress is not None and cells[_PROGRESS] != seen:
                    seen = float(cells[_PROGRESS])
                    options.progress(int(cells[_DONE]), int(cells[_TOTAL]), float(cells[_SIM]))
                if following is not None and not ready:
                    worked = _follow(*following)
                    if worked is None:  # the follower failed: the run goes on without it
                        following = None
                    else:
                        cells[_FRONT] = following[0].front
                    busy = bool(worked)
            except KeyboardInterrupt as exc:  # SIGINT/SIGTERM/SIGHUP here: the child stops too
                if reason is None:
                    reason = stop_reason(exc)
                    cells[_FRONT] = _NO_SHARE  # a child formatting its share stops now
                    deadline = time.monotonic() + STOP_GRACE
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, signal.Signals[reason])
    finally:
        ended.close()
    return b"".join(chunks), reason


class _Ended:
    """Whether the guarded child has ended, without reaping it: its pidfd is readable from
    then on (``fds``, for ``select``); without pidfds (Linux < 5.3) a look at every tick."""

    def __init__(self, pid: int) -> None:
        self._pid = pid
        self._pidfd = -1
        with contextlib.suppress(OSError, AttributeError):
            self._pidfd = os.pidfd_open(pid)
        self.fds = [self._pidfd] if self._pidfd >= 0 else []

    def __call__(self) -> bool:
        if self._pidfd >= 0:
            return bool(select.select([self._pidfd], [], [], 0.0)[0])
        try:
            found = os.waitid(os.P_PID, self._pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return True
        return found is not None

    def close(self) -> None:
        if self._pidfd >= 0:
            os.close(self._pidfd)
            self._pidfd = -1


def _drain(pipe: int) -> list[bytes]:
    """What the pipe holds now, read without waiting for its end."""
    chunks = []
    os.set_blocking(pipe, False)
    try:
        while chunk := os.read(pipe, 1 << 20):
            chunks.append(chunk)
    except BlockingIOError:
        pass
    finally:
        os.set_blocking(pipe, True)
    return chunks


def _tick(following: tuple[Follower, Published] | None) -> float:
    """Seconds to wait for the child's message: short while a follower keeps up with it."""
    return 0.1 if following is None else 0.02


def _follow(follower: Follower, published: Published) -> bool | None:
    """One piece of the follower's work; None when it failed (it is then left out: what it
    does is an optimisation, and a run's results must not depend on it)."""
    try:
        return follower.follow(published)
    except (KeyboardInterrupt, SystemExit):
        raise
    except Exception:  # whatever the follower hit, the run goes on
        logger.debug("guardian: the follower failed; the run goes on without it", exc_info=True)
        return None


def _reap(pid: int) -> int:
    """The child's wait status (retried through signals)."""
    while True:
        try:
            return os.waitpid(pid, 0)[1]
        except ChildProcessError:
            return 0
        except KeyboardInterrupt:
            continue


def _unpickle(data: bytes, shared: _Shared) -> tuple[RunResult, object] | None:
    """The child's result and where it left its share of the follower's work, when it wrote
    them whole (it is our own forked process)."""
    if len(data) != _RESULT_MESSAGE:
        return None
    offset = int.from_bytes(data[:8], "little")
    length = int.from_bytes(data[8:], "little")
    size = os.fstat(shared.fd).st_size
    if offset < CONTROL or offset + length > size:
        return None
    with mmap.mmap(shared.fd, size, prot=mmap.PROT_READ) as view:
        outcome = pickle.loads(view[offset : offset + length])
    if not (isinstance(outcome, tuple) and len(outcome) == 2):
        return None
    result, placed = outcome
    return (result, placed) if isinstance(result, RunResult) else None


def _how(status: int, *, of_process: bool = False) -> str:
    """How the child ended, said of the model that ended it, or ``of_process``: of the run's
    process itself (the sentence's subject)."""
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"crashed with {signal.Signals(number).name}"
        except ValueError:
            return f"was killed by signal {number}"
    code = os.waitstatus_to_exitcode(status)
    ended = "ended" if of_process else "ended the run's process"
    return f"{ended} with exit status {code}"


def _salvage(
    system: CompiledSystem, shared: _Shared, status: int, reason: str | None, wall: float
) -> RunResult:
    """The result of a child that died: every completed step, a fault naming who was stepping
    (or instantiating, initializing, terminating)."""
    directory = shared.directory() or {"tracks": [], "order": [], "works": []}
    run = system.run
    works: list[str] = directory.get("works", [])
    index, t, steps_done, place = _blamed(shared, directory, system)
    phase, who = int(shared.cells[_PHASE]), int(shared.cells[_PHASE_WHO])
    if phase in (_TERMINATE, _ENDED):  # the loop is over: its steps are those recorded
        recorded = _steps_recorded(shared, directory, run.steps)
        steps_done, place = (steps_done if recorded is None else recorded), -1
        t = run.start + steps_done * run.step
    signals = _table(shared, directory, steps_done, place)
    if reason is not None:  # stopped, then killed when it did not stop: interrupted
        return RunResult.after(
            system, BACKEND_NAME, RunStatus.INTERRUPTED, steps_done, wall, signals,
            interrupted_by=reason,
        )  # fmt: skip
    how = _how(status)
    guarded = "the run was guarded in a process of its own"
    names = [c.name for c in system.components]
    if phase in _PHASE_LABELS and 0 <= who < len(names):
        when = t if phase == _TERMINATE else run.start
        label = _PHASE_LABELS[phase]
        error = fault(names[who], f"the model {how} in {label} ({guarded})", time=when)
    elif phase == _ENDED:
        how = _how(status, of_process=True)
        error = RunError(f"the run's process {how} after its models were terminated", time=t)
    elif 0 <= index < len(works) and works[index]:
        label = works[index]
        functions = directory.get("functions")
        function = functions.get(label) if isinstance(functions, dict) else None
        if isinstance(function, str):  # a component stepped alone: its step is this call
            where = (
                f"during its step, in {function} or the calls that set its inputs and get its "
                f"outputs ({guarded}; `--isolate {label}` tells the exact FMI function)"
            )
        else:
            where = (
                f"during its step ({guarded}; `--isolate` with the component's name tells the "
                "FMI function)"
            )
        error = fault(label, f"the model {how} {where}", time=t)
    else:
        how = _how(status, of_process=True)
        error = RunError(f"the run's process {how} while preparing the run", time=run.start)
    return RunResult.after(system, BACKEND_NAME, RunStatus.FAULT, steps_done, wall, signals, error)


def _steps_recorded(shared: _Shared, directory: dict[str, Any], steps: int) -> int | None:
    """Base steps every track has recorded (after the loop: the steps done); None: no track.

    A track of period p with c rows has recorded steps up to (c - 1) p: its first row is
    the start (outputs) or the step from it (inputs, recorded before the step).
    """
    done: int | None = None
    for entry in directory.get("tracks", []):
        try:
            count = shared.count(int(entry["offset"]), int(entry["capacity"]))
            covered = (count - 1) * int(entry["period"])
        except (KeyError, TypeError, ValueError):
            continue
        if count > 0 and entry.get("columns"):
            done = covered if done is None else min(done, covered)
    return None if done is None else max(0, min(steps, done))


def _blamed(
    shared: _Shared, directory: dict[str, Any], system: CompiledSystem
) -> tuple[int, float, int, int]:
    """(work index, t, steps done, place) of the step to blame for a crash; index -1: none.

    The steps that may have been under way: the loop's marked work and each lane's step in
    flight. The earliest in the sequential order is blamed, as the sequential run would have
    met it first; the steps done are those before its communication point.
    """
    cells = shared.cells
    run = system.run
    places: list[int] = directory.get("places", [])
    marks: list[tuple[int, int, int, float]] = []  # (n, place, work index, t)
    for base in range(_LANES, _CELLS, _LANE_CELLS):
        lane = int(cells[base + _LANE_WORK])
        if lane >= 0:
            n, place = int(cells[base + _LANE_N]), int(cells[base + _LANE_PLACE])
            marks.append((n, place, lane, float(cells[base + _LANE_T])))
    index = int(cells[_WORK])
    if index >= 0:
        t = float(cells[_T])
        n = round((t - run.start) / run.step)
        loop = (n, places[index] if index < len(places) else -1, index, t)
        if not _stale(loop, marks):
            marks.append(loop)
    if not marks:
        return -1, run.start, 0, -1
    n, place, index, t = min(marks)
    return index, t, max(0, min(run.steps, n)), place


def _stale(loop: tuple[int, int, int, float], lanes: list[tuple[int, int, int, float]]) -> bool:
    """Whether the loop's mark is a step it had finished: the loop never clears its mark (a
    store per step), but it hands steps to lanes in the sequential order, after its own
    earlier work is done; so a lane step in flight later in that order than the loop's mark
    proves the marked step complete."""
    n, place = loop[0], loop[1]
    return place >= 0 and any(
        lane_place >= 0 and (lane_n, lane_place) > (n, place) for lane_n, lane_place, _, _ in lanes
    )


def _table(
    shared: _Shared, directory: dict[str, Any], steps_done: int, place: int = -1
) -> dict[str, npt.NDArray[np.float64]]:
    """The recorder's base-step columns, rebuilt from the shared tracks.

    With the parallel schedule the loop may have recorded the inputs of work after the
    blamed step (at ``place`` in the order, from ``steps_done``) while that step ran on its
    lane: those rows, which the sequential run never recorded, are left out.
    """
    rebuilt = recording.Recorder()
    rebuilt.order.extend(directory.get("order", []))
    for entry in directory.get("tracks", []):
        columns = list(entry["columns"])
        count, rows = shared.rows(int(entry["offset"]), int(entry["capacity"]), len(columns))
        period = int(entry["period"])
        track = recording.Track(period, int(entry["capacity"]), columns)
        track.rows, track.count = rows, count
        own = int(entry.get("place", -1))
        if place >= 0 and own >= 0 and own != place:
            issued = -(-steps_done // period)  # steps the sequential order issued before
            if steps_done % period == 0 and own < place:
                issued += 1
            track.truncate(issued + 1 if entry.get("outputs") else issued)
        rebuilt.tracks.append(track)
    return rebuilt.table(steps_done)


def guard(
    system: CompiledSystem, run_fn: RunFunction, follower: Follower | None = None
) -> RunFunction:
    """``run_fn`` (``system.run``), run under the guardian (``follower``: see run_guarded)."""

    def guarded(*, options: RunOptions) -> RunResult:
        return run_guarded(system, run_fn, options, follower)

    return guarded


__all__ = ["GUARDIAN", "available", "guard", "run_guarded"]
