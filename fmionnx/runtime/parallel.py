"""The parallel schedule: which steps may run on a worker thread, decided before the loop.

The sequential schedule (``docs/execution.md``) issues, at each communication point, the due
work in the compiled order; each piece of work copies its inputs (its connections' transfers),
records them, steps, and records its outputs. The parallel schedule issues exactly the same
work in exactly the same order on the loop's thread, with one difference: the *step* of some
components is handed to a worker thread of its own (a :class:`Lane`) and the loop goes on with
the work after it. Before any later work that touches what that step touches, the loop waits
for it (a *join*). What a pending step touches is known before the loop:

* it writes its own component (its output buffers and its model's state) and reads only its
  own input buffers, which its transfers filled on the loop's thread before it was handed
  over; nothing but its own transfers writes them.

So later work must join a pending step of component ``C`` exactly when it *is* ``C`` (its
next step: its transfers would overwrite the inputs in use) or *reads* ``C`` (a transfer from
one of ``C``'s outputs, a camera of ``C`` rendered, a native group or iterated loop whose
internal connections come from ``C``). Every value read is then written by the same producer
step as in the sequential order: a reader issued after ``C``'s step waits for it, a reader
issued before it ran before it was handed over. Recording of the step's outputs happens at the
join, in the component's own track, so the recorded rows are the sequential ones too.

Which steps go to a worker is a cost choice, not a semantic one (the values do not depend on
it): a step whose library releases the GIL for long enough to pay for the hand-over (an ONNX
session's run — the ONNX runner says so with ``releases_gil = True`` — or a round trip to an
isolated component's process), at an occurrence where the next work issued does not have to join
it (otherwise nothing could overlap). Native groups and iterated loops always run on the loop's
thread.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass

from fmionnx.runtime.stopping import shield_begin, shield_end
from fmionnx.runtime.watchdog import Marker

#: Set on a lane's thread: see :func:`on_lane`.
_this_thread = threading.local()


def on_lane() -> bool:
    """Whether the calling thread is a :class:`Lane`'s worker.

    A wait that could spin (an isolated component's round trip) must not on a lane: a spin
    holds the GIL, which the loop's thread needs meanwhile. Any other thread runs a loop of its
    own -- ``fmionnx run``'s main thread, a sweep worker's task thread, a node -- and may.
    """
    return getattr(_this_thread, "lane", False)


@dataclass(frozen=True, slots=True)
class Footprint:
    """What one piece of scheduled work touches: its components, and those it reads."""

    members: frozenset[str]
    reads: frozenset[str]

    def must_join(self, pending: Footprint) -> bool:
        """Whether this work must wait for a pending step of ``pending``'s component."""
        return not (
            pending.members.isdisjoint(self.members) and pending.members.isdisjoint(self.reads)
        )


@dataclass(slots=True)
class Job:
    """One step handed to a lane: the work, its time and its place in the sequential order."""

    work: object
    step: Callable[[float, float], None]
    t: float
    h: float
    n: int
    index: int


class Lane:
    """A worker thread that runs one component's steps, one at a time, in the order given.

    A lane holds at most one pending job: the component's next step joins the previous one
    (it is a conflict), so steps of one component never overlap each other.
    """

    def __init__(self, name: str, marker: Marker | None = None) -> None:
        self.name = name
        #: Told when a step starts and ends on this lane (the guardian's marker records it).
        self._marker = marker if marker is not None else Marker()
        self.job: Job | None = None
        self.steps = 0
        self._inbox: queue.SimpleQueue[Job | None] = queue.SimpleQueue()
        #: Set by the worker when the pending job finished; its outcome is in ``_outcome``.
        #: Waiting on an event consumes nothing, so a wait cut short by a stop signal can
        #: simply be waited again (a queue's ``get`` cut after it returned would lose it).
        self._finished = threading.Event()
        self._outcome: BaseException | None = None
        self._thread: threading.Thread | None = None

    def submit(self, job: Job) -> None:
        """Hand ``job`` to the worker (started on first use)."""
        shield_begin()  # the pending job and the queued job are one, whatever signal comes
        try:
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._serve, name=f"fmionnx-step-{self.name}", daemon=True
                )
                self._thread.start()
            self._finished.clear()
            self.job = job
            self.steps += 1
            self._inbox.put(job)
        finally:
            shield_end()

    def wait_finished(self) -> None:
        """Block until the pending job has finished (a stop signal may interrupt it: then
        nothing changed, and it can be called again)."""
        assert self.job is not None
        self._finished.wait()

    def take(self) -> tuple[Job, BaseException | None]:
        """The finished job and what it raised (None: it completed); the lane is free again.

        Call inside a shield (:func:`~fmionnx.runtime.stopping.shield_begin`) together with
        whatever must follow it, after :meth:`wait_finished`.
        """
        job = self.job
        assert job is not None
        assert self._finished.is_set()
        self.job = None
        return job, self._outcome

    def wait(self) -> tuple[Job, BaseException | None]:
        """Wait for the pending job; returns it and what it raised (None: it completed)."""
        self.wait_finished()
        shield_begin()
        try:
            return self.take()
        finally:
            shield_end()

    def done(self) -> bool:
        """Whether the pending job has finished (its outcome can be taken without waiting)."""
        return self._finished.is_set()

    def close(self) -> None:
        """Let the worker end after its pending job (it is a daemon: it never keeps us alive)."""
        if self._thread is not None:
            self._inbox.put(None)
            self._thread = None

    def _serve(self) -> None:
        _this_thread.lane = True
        inbox, marker = self._inbox, self._marker
        while True:
            job = inbox.get()
            if job is None:
                return
            outcome: BaseException | None = None
            marker.lane_started(job)
            try:
                job.step(job.t, job.h)
            except BaseException as exc:  # handed to the loop's thread, which decides
                outcome = exc
            marker.lane_ended(job)
            self._outcome = outcome
            self._finished.set()


@dataclass(frozen=True, slots=True)
class Issue:
    """One piece of work at one slot of the tabulated schedule, as the parallel loop issues it.

    ``joins``: lanes to wait for first (those whose pending step this work must join);
    ``lane``: the lane its step runs on, or None to step it on the loop's thread.
    """

    work: object
    joins: tuple[Lane, ...]
    lane: Lane | None


def plan(
    table: Sequence[Sequence[object]],
    footprints: dict[int, Footprint],
    concurrent: Collection[int],
    lanes: dict[int, Lane],
) -> list[tuple[Issue, ...]]:
    """The parallel table: for each slot of ``table``, each work with its joins and lane.

    ``footprints`` and ``lanes`` are keyed by ``id(work)``; ``concurrent`` holds the ids of
    work that may run on a lane. A concurrent work is handed over at an occurrence only when
    the next work issued (in this slot or the following ones, cyclically) need not join it.
    """
    joins = {
        key: tuple(lanes[c] for c in concurrent if footprint.must_join(footprints[c]))
        for key, footprint in footprints.items()
    }
    order = [(k, i) for k, slot in enumerate(table) for i in range(len(slot))]
    following: dict[tuple[int, int], object] = {}
    for position, (k, i) in enumerate(order):
        k2, i2 = order[(position + 1) % len(order)]
        following[(k, i)] = table[k2][i2]
    out = []
    for k, slot in enumerate(table):
        issues = []
        for i, work in enumerate(slot):
            key = id(work)
            lane = None
            if key in concurrent:
                after = following[(k, i)]
                if not footprints[id(after)].must_join(footprints[key]):
                    lane = lanes[key]
            issues.append(Issue(work, joins[key], lane))
        out.append(tuple(issues))
    return out


def footprint(members: Iterable[str], sources: Iterable[str]) -> Footprint:
    """The footprint of work stepping ``members`` whose connections read ``sources``."""
    own = frozenset(members)
    return Footprint(own, frozenset(sources) - own)
