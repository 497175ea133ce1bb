"""Free run: which sample of a subscribed topic a node steps on, chosen by stamp, not arrival.

A free-run node used to step on whatever arrived last. Topics travel separately (DDS data by
multicast, Zenoh key expressions, another host), so a small ``/clock`` tick can overtake a
camera frame and the detector then steps on the previous frame. Here every sample is placed by
its *stamp* and a step takes the sample of its own time:

* **Stamp.** The message header's stamp when the type starts with ``std_msgs/Header``
  (decoded from the first 8 bytes after the CDR encapsulation, without deserialising the
  message), otherwise the middleware's source timestamp (which the writing node sets to the
  same simulated time). A stamp is expressed as a base-step index of the run.
* **Expected sample.** A node at base step ``n`` (position ``p`` in ``CompiledSystem.order``)
  expects, per topic published inside the run, the sample its producer published last with a
  key before ``(n, p)``: exactly the sample a lockstep run reads (:mod:`.schedule`). Its stamp
  follows from the compiled system alone (:func:`expected_stamp`): a producer step at ``m``
  publishes its outputs stamped ``m + period``, the values after set-up are stamped 0.
* **Future samples** (stamped later than expected) are kept until a step expects them.
* **Stale step**: the expected sample did not come within the wait (the node decides how long);
  the step uses the newest older sample it has. After a stale step the topic is *silent*: no
  step waits for it again until a new sample of it arrives, so a producer that stopped or
  never started costs one wait, not one per step.
* **Late sample**: a sample used after a step that waited for it in vain.
* **Dropped sample**: a sample that a step waited for in vain and no step used (lost on the
  way, or never published). Steps while the topic is silent are stale but wait for nothing,
  so they record no expectation: a producer that stopped adds one dropped sample, not one per
  step, and the bookkeeping stays bounded for a run of any length (at most ``MAX_PENDING``
  expectations are kept; older ones, and those at or below the sample in use, which no step
  can use any more, are counted as dropped and forgotten).

Topics that no node of the run publishes (a real camera) and samples without a usable stamp
(rclpy cannot set a source timestamp, so headerless messages through rclpy; a source timestamp
outside the run's time) are taken by arrival: the newest one.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass, field

from fmionnx.backends.ros2.schedule import TopicSchedule
from fmionnx.compile.ros2.messages import RosDistro, members, resolve_field

#: ``builtin_interfaces/Time`` (int32 sec, uint32 nanosec) right after the encapsulation header.
_STAMP_LE = struct.Struct("<iI")
_STAMP_BE = struct.Struct(">iI")
_HEADER_TYPE = "std_msgs/msg/Header"
#: Samples kept per topic waiting for their step; beyond, the oldest go (a runaway producer).
#: Also the number of missed expectations kept per topic; beyond, the oldest count as dropped.
MAX_PENDING = 512


class Match(enum.StrEnum):
    """Where a topic's samples get their stamps (reported in ``run.json``)."""

    HEADER = "header"
    SOURCE = "source timestamp"
    ARRIVAL = "arrival"


def starts_with_header(msgtype: str, distro: RosDistro) -> bool:
    """Whether ``msgtype``'s first member is a ``std_msgs/msg/Header`` named ``header``."""
    names = members(msgtype, distro)
    if not names or names[0] != "header":
        return False
    return resolve_field(msgtype, "header", distro).base == _HEADER_TYPE


def header_stamp_ns(data: bytes) -> int | None:
    """The header stamp (ns) of a CDR sample whose message starts with a header.

    The header is the first member and its stamp the header's first, so the stamp sits right
    after the 4-byte encapsulation header, 4-aligned; the encapsulation's low bit says the
    byte order. None for a sample too short to hold one.
    """
    if len(data) < 12:
        return None
    layout = _STAMP_LE if data[1] & 1 else _STAMP_BE
    sec, nanosec = layout.unpack_from(data, 4)
    return int(sec) * 1_000_000_000 + int(nanosec)


@dataclass(frozen=True)
class StepScale:
    """Seconds (ns) of simulated time <-> base-step indices of one run of ``steps`` steps."""

    start: float
    step: float
    #: Base steps of the run (0: any stamp is plausible).
    steps: int = 0

    def plausible(self, index: int) -> bool:
        """Whether a source timestamp can be one a node of this run set (a writer that did
        not set it, e.g. rclpy, or a negative start time, leaves a wall clock there)."""
        return self.steps <= 0 or 0 <= index <= 2 * self.steps + 1

    def index(self, stamp_ns: int) -> int:
        """The base step nearest to ``stamp_ns`` (stamps of the run lie on the grid)."""
        return round((stamp_ns * 1e-9 - self.start) / self.step)

    def seconds(self, index: int) -> float:
        """The simulated time of base step ``index`` (for messages)."""
        return self.start + index * self.step


def expected_stamp(schedule: TopicSchedule, n: int, position: int) -> int | None:
    """The stamp (base-step index) of the sample a reader at ``(n, position)`` should use.

    The producer's last publication with a key before ``(n, position)``: its step ``m``
    (``m < n``, or ``m <= n`` when it comes earlier in the order) that published, stamped
    ``m + period``; else the values after set-up (stamp 0), or None when those were not
    published either (a lazy image nobody could have read yet).
    """
    period = schedule.period
    last = n if schedule.position < position else n - 1
    m = (last // period) * period
    while m >= 0:
        if schedule.published_at(m):
            return m + period
        m -= period
    return 0 if schedule.published_at_init() else None


@dataclass
class InputCounts:
    """What happened to one subscribed topic of a free-run node."""

    match: Match
    received: int = 0
    matched: int = 0
    stale: int = 0
    late: int = 0
    dropped: int = 0

    def as_json(self) -> dict[str, str | int]:
        """The ``run.json`` form."""
        return {
            "match": self.match.value,
            "received": self.received,
            "matched": self.matched,
            "stale": self.stale,
            "late": self.late,
            "dropped": self.dropped,
        }


@dataclass
class StampedInput:
    """The samples of one topic, held by stamp until a step uses them, and their counts.

    Pure bookkeeping (no waiting, no decoding): the node offers samples as they arrive, asks
    :meth:`ready` while it waits, and :meth:`use` once per step for the payload to load.
    """

    match: Match
    scale: StepScale
    #: Samples not used yet, by stamp (one writer: a repeated stamp replaces the sample).
    pending: dict[int, bytes] = field(default_factory=dict)
    #: Stamp of the sample in use (None before the first).
    current: int | None = None
    #: Expected stamps that a step waited for in vain and no step has used yet (at most
    #: ``MAX_PENDING``, all above ``current``).
    missed: set[int] = field(default_factory=set)
    #: Missed expectations already settled as dropped (evicted or passed by ``current``).
    settled_dropped: int = 0
    #: Arrival mode: the newest sample not yet used.
    newest: bytes | None = None
    #: A step went stale and no sample arrived since: do not wait for this topic.
    silent: bool = False
    counts: InputCounts = field(init=False)

    def __post_init__(self) -> None:
        self.counts = InputCounts(self.match)

    def stamp_of(self, data: bytes, source_ns: int | None) -> int | None:
        """The base-step stamp of a sample (None: it has none this topic can use)."""
        if self.match is Match.HEADER:
            ns = header_stamp_ns(data)
            return None if ns is None else self.scale.index(ns)
        if self.match is Match.ARRIVAL or source_ns is None:
            return None
        index = self.scale.index(source_ns)
        return index if self.scale.plausible(index) else None  # None: no simulated time

    def offer(self, data: bytes, source_ns: int | None) -> None:
        """One arrived sample with the middleware's source timestamp (ns, or None)."""
        self.counts.received += 1
        self.silent = False
        stamp = self.stamp_of(data, source_ns)
        if stamp is None:
            if self.match is Match.SOURCE:  # the middleware cannot carry one (rclpy)
                self.match = self.counts.match = Match.ARRIVAL
            if self.match is Match.ARRIVAL:
                self.newest = data
                return
            stamp = -1  # a header too short to read: older than anything
        if self.current is not None and stamp <= self.current:
            return  # older than the sample in use: no step can want it any more
        self.pending[stamp] = data
        if len(self.pending) > MAX_PENDING:
            del self.pending[min(self.pending)]

    def ready(self, expected: int | None) -> bool:
        """Whether a step expecting the sample stamped ``expected`` need not wait any longer.

        True when that sample is here or in use, when nothing is expected, when a step already
        waited for it in vain, when the topic has been silent since a stale step, and when a
        newer sample arrived (one writer's samples arrive in order, so the expected one is lost).
        """
        if self.match is Match.ARRIVAL or expected is None or self.silent:
            return True
        if expected == self.current or expected in self.pending or expected in self.missed:
            return True
        return any(stamp > expected for stamp in self.pending)

    def take_start(self, stamp: int | None) -> bytes | None:
        """The producer's values after set-up (stamped ``stamp``), if here, for a model's
        outputs at the start time (``startinputs``).

        That is no step: nothing is counted. A topic matched by arrival gives its newest
        sample and keeps it for the first step.
        """
        if self.match is Match.ARRIVAL:
            return self.newest
        if stamp is None or stamp not in self.pending:
            return None
        self.current = stamp
        return self.pending.pop(stamp)

    def use(self, expected: int | None) -> bytes | None:
        """The payload to load for a step expecting ``expected`` (None: keep the values held).

        Counts the step as matched or stale; loads the expected sample when it is here, else
        the newest older one (never a sample from the future).
        """
        if self.match is Match.ARRIVAL:
            data, self.newest = self.newest, None
            return data
        if expected is None or expected == self.current:
            return None
        if expected in self.pending:
            self.counts.matched += 1
            chosen = expected
        else:
            self.counts.stale += 1
            if not self.silent:  # a silent topic's step waited for nothing: expects nothing
                self._miss(expected)
            self.silent = True
            older = [stamp for stamp in self.pending if stamp < expected]
            if not older:
                return None
            chosen = max(older)
        data = self.pending[chosen]
        if chosen in self.missed:
            self.missed.discard(chosen)
            self.counts.late += 1
        self.current = chosen
        for stamp in [s for s in self.pending if s <= chosen]:
            del self.pending[stamp]
        passed = [s for s in self.missed if s <= chosen]  # older than the sample in use:
        self.missed.difference_update(passed)  # offer() discards them, no step can use them
        self.settled_dropped += len(passed)
        self._count_dropped()
        return data

    def _miss(self, expected: int) -> None:
        """Record a stamp a step waited for in vain, within the window of ``MAX_PENDING``."""
        self.missed.add(expected)
        if len(self.missed) > MAX_PENDING:
            self.missed.discard(min(self.missed))
            self.settled_dropped += 1
        self._count_dropped()

    def _count_dropped(self) -> None:
        self.counts.dropped = self.settled_dropped + len(self.missed)

    def finish(self) -> InputCounts:
        """The counts at the end of the run (expected samples never used are dropped)."""
        self._count_dropped()
        return self.counts
