"""One component as a ROS 2 node: its in-process runner between DDS readers and writers.

The node reuses the in-process pieces unchanged: the component's runner
(:func:`~fmionnx.kinds.registry.make_runner`), the connection transfers
(:func:`~fmionnx.runtime.transfer.make_transfer`: element selection,
``factor*x+offset``, dtype conversion, NaN check) and the recorder tracks. What differs is where
a producer's value comes from: a *proxy* buffer per producer port, shaped and typed like the
producer's own output buffer, filled from the decoded message. A lockstep node therefore feeds
its runner exactly the bytes the in-process master would.

Time: every node follows ``/clock``. ``lockstep``: the supervisor publishes ``t_n`` and waits
for ``/fmionnx/done`` from every node due at ``n``; a due node reads, per subscribed topic, the
sample number :meth:`TopicSchedule.count_before` names (the producer's step-``n`` value when it
runs earlier in the order, else the held one), steps, publishes, reports done. ``free``: the
simulator node steps at its own pace (``rtf`` times real time) and publishes ``/clock``; every
other node steps at its grid points once the clock has passed them, after every input delivered
a first sample, on the input samples *of its time* (matched by stamp, :mod:`.inputsync`),
waiting for a late one at most ``input_wait`` seconds.
"""

from __future__ import annotations

import enum
import logging
import signal
import time
from collections import deque
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from types import FrameType

import numpy as np

from fmionnx.backends.ros2.codec import TopicCodec
from fmionnx.backends.ros2.control import (
    CLOCK_DDS,
    CONTROL_READER_QOS,
    CONTROL_WRITER_QOS,
    DONE_DDS,
    DONE_TYPE,
    READY_DDS,
    READY_TYPE,
    StepClock,
    encode_ready,
)
from fmionnx.backends.ros2.discovery import GraphAnnouncer, NodeEntities
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.inputsync import (
    Match,
    StampedInput,
    StepScale,
    expected_stamp,
    starts_with_header,
)
from fmionnx.backends.ros2.middleware import (
    Middleware,
    NodeTransport,
    SampleReader,
    SampleWriter,
    open_transport,
)
from fmionnx.backends.ros2.recording import NodeRecording, node_recording, record_refs, save_node
from fmionnx.backends.ros2.schedule import TopicSchedule, topic_schedules
from fmionnx.backends.ros2.startinputs import evaluate_at_start
from fmionnx.backends.ros2.transport import Participant, RawReader, RawWriter
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import DEFAULT_DISTRO, RosDistro
from fmionnx.compile.ros2.names import dds_topic
from fmionnx.compile.ros2.plan import CLOCK_TYPE
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability
from fmionnx.compile.ros2.types import NodePlan, Ros2Plan, TopicPlan
from fmionnx.core.errors import FmionnxError, ModelTerminated, RunError
from fmionnx.core.runner import Buffer, Runner, Wiring
from fmionnx.core.types import Component, DType
from fmionnx.kinds.base import SIMULATOR
from fmionnx.kinds.registry import has_capability, make_runner
from fmionnx.runtime.profile import Profile
from fmionnx.runtime.result import Detail
from fmionnx.runtime.stepping import Work
from fmionnx.runtime.transfer import NonFiniteWatch, Transfer, make_transfer

log = logging.getLogger("fmionnx.node")

#: Seconds a writer waits for the readers of the run before publishing its first sample.
MATCH_TIMEOUT = 60.0
#: Free run: default seconds a step waits for an input sample of its time (``--input-wait``).
INPUT_WAIT = 0.1
#: Free run: stale steps logged per input (the rest are only counted).
STALE_LOGGED = 5
#: Seconds a node waits for its first ``/clock`` sample before its log says who should send it.
CLOCK_SILENCE = 5.0
#: Exit status of a node whose model ended the simulation (FMI ``terminateSimulation``): not
#: a fault; its status file says who ended the run and when (``docs/ros2.md``).
ENDED_BY_MODEL = 3


class SyncMode(enum.StrEnum):
    """How nodes share simulated time."""

    LOCKSTEP = "lockstep"
    FREE = "free"


class NodeError(FmionnxError):
    """The node cannot start: its COMPONENT argument names no component of the system, or an
    ``external`` one (whose topics come from outside). ``fmionnx node`` reports it as a usage
    error (exit 2), as ``run`` does an unknown name in ``--param``."""


@dataclass(frozen=True)
class NodeOptions:
    """How one node runs; the supervisor passes the same to all of them."""

    sync: SyncMode = SyncMode.LOCKSTEP
    distro: RosDistro = DEFAULT_DISTRO
    record_dir: Path | None = None
    supervised: bool = False
    rtf: float = 1.0
    middleware: Middleware = Middleware.DDS
    #: Free run: seconds a step waits for an input sample of its time before going stale.
    input_wait: float = INPUT_WAIT
    #: ROS topic remappings ``(from, to)`` of this node's publishers and subscriptions.
    remap: tuple[tuple[str, str], ...] = ()
    #: ``zenoh``: the router endpoint to connect to ("" : the Zenoh configuration's).
    zenoh_router: str = ""
    #: Time the component's phases (``--profile``): its status file's ``statistics``.
    profile: bool = False
    #: ``fault`` or ``warn``: a non-finite value arriving on a connection (``--on-nonfinite``).
    on_nonfinite: str = "fault"
    #: Free run of a system without a simulator and without a supervisor (``--clock-source``,
    #: a launch file): this node publishes ``/clock``, as a simulator node would.
    clock_source: bool = False


def clock_source(system: CompiledSystem, plan: Ros2Plan) -> str | None:
    """The component whose node publishes ``/clock`` in a free run: the first simulator."""
    running = {n.component for n in plan.nodes}
    for name in system.order:
        if name in running and has_capability(system.component(name), SIMULATOR):
            return name
    return None


class ProxyRunner:
    """Stands in for a producer in another process: its output buffers, filled from DDS."""

    def __init__(self, component: Component) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        self._buffers: dict[str, Buffer] = {}

    def output_buffer(self, port: str) -> Buffer:
        """A flat buffer typed like the producer's port (made on first use)."""
        buffer = self._buffers.get(port)
        if buffer is None:
            spec = self.component.port(port)
            dtype = np.float64 if spec.dtype in (DType.STRING, DType.BINARY) else spec.dtype.value
            buffer = np.zeros(1 if spec.size is None else spec.size, dtype=dtype)
            self._buffers[port] = buffer
        return buffer

    def has(self, port: str) -> bool:
        """Whether a transfer reads ``port``."""
        return port in self._buffers

    # The rest of the runner protocol: a proxy never runs anything.
    def instantiate(self) -> None:
        """Nothing to load."""

    def setup(self, start: float, stop: float) -> None:
        """Nothing to initialise."""

    def input_buffer(self, port: str) -> Buffer:
        """A proxy has no inputs."""
        raise KeyError(port)

    def step(self, t: float, h: float) -> None:
        """A proxy never steps."""

    def produce(self, port: str) -> None:
        """Nothing is lazy."""

    def terminate(self) -> None:
        """Nothing to free."""


@dataclass
class Inbox:
    """One subscribed topic: its reader, the samples not yet used, where values go."""

    topic: TopicPlan
    reader: SampleReader
    codec: TopicCodec
    schedule: TopicSchedule | None
    sinks: list[tuple[str, Buffer]]
    queue: deque[tuple[int, bytes]] = field(default_factory=deque)
    received: int = 0
    used: int = 0
    #: Free run: the samples by stamp (None in lockstep).
    stamped: StampedInput | None = None
    stale_logged: int = 0

    def drain(self) -> None:
        """Move every waiting sample into the queue, numbered from 1."""
        while True:
            samples = self.reader.take(256)
            for data in samples:
                self.received += 1
                self.queue.append((self.received, data))
            if len(samples) < 256:
                return

    def _apply(self, index: int, data: bytes) -> None:
        if index == self.used:
            return
        values, _ = self.codec.decode(data)
        for port, buffer in self.sinks:
            np.copyto(buffer, values[port].reshape(buffer.shape), casting="unsafe")
        self.used = index

    def exact(self, needed: int) -> None:
        """Lockstep: load sample number ``needed``, waiting for it (held values: no decode)."""
        while True:
            self.drain()
            while self.queue and self.queue[0][0] < needed:
                self.queue.popleft()
            if self.queue:
                index, data = self.queue[0]
                self._apply(index, data)
                return
            if needed <= self.used:
                return
            self.reader.wait(0.5)

    def collect(self) -> None:
        """Free run: hand every waiting sample, with its source timestamp, to :attr:`stamped`."""
        assert self.stamped is not None
        while True:
            samples = self.reader.take_stamped(256)
            for data, source_ns in samples:
                self.received += 1
                self.stamped.offer(data, source_ns)
            if len(samples) < 256:
                return

    def expected(self, n: int, position: int) -> int | None:
        """Free run: the stamp a step at ``(n, position)`` expects (None: any, by arrival)."""
        if self.schedule is None:
            return None
        return expected_stamp(self.schedule, n, position)

    def settle(self, expected: int | None, deadline: float) -> None:
        """Free run: collect samples until the expected one is here or ``deadline`` passed."""
        assert self.stamped is not None
        self.collect()
        while not self.stamped.ready(expected):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return
            self.reader.wait(min(remaining, 0.05))
            self.collect()

    def load(self, expected: int | None, step_time: float, level: int = logging.WARNING) -> None:
        """Free run: load the sample :meth:`StampedInput.use` chooses, logging a stale step."""
        assert self.stamped is not None
        stale = self.stamped.counts.stale
        data = self.stamped.use(expected)
        if self.stamped.counts.stale > stale and self.stale_logged < STALE_LOGGED:
            self.stale_logged += 1
            scale, current = self.stamped.scale, self.stamped.current
            used = (
                "the values held" if current is None
                else f"the one stamped {scale.seconds(current):g} s"
            )  # fmt: skip
            log.log(
                level, "t=%g s: %s: the sample stamped %g s did not come in time; stepped on %s%s",
                step_time, self.topic.name, scale.seconds(expected or 0), used,
                " (further stale steps are only counted)" if self.stale_logged == STALE_LOGGED
                else "",
            )  # fmt: skip
        if data is not None:
            values, _ = self.codec.decode(data)
            for port, buffer in self.sinks:
                np.copyto(buffer, values[port].reshape(buffer.shape), casting="unsafe")

    def newest(self) -> None:
        """Lockstep, topics from outside the run: load the newest sample, if any."""
        self.drain()
        if self.queue:
            index, data = self.queue[-1]
            self.queue.clear()
            self._apply(index, data)


@dataclass
class Outbox:
    """One published topic: its writer, codec, the ports that fill it."""

    topic: TopicPlan
    writer: SampleWriter
    codec: TopicCodec
    schedule: TopicSchedule
    values: dict[str, Buffer]
    lazy: tuple[str, ...]
    readers: int


def _wiring(system: CompiledSystem, component: Component) -> Wiring:
    incoming = system.inputs_of(component.name)
    sizes: dict[str, int] = {}
    for connection in incoming:
        sizes[connection.dst.port] = sizes.get(connection.dst.port, 0) + connection.size
    return Wiring(frozenset(c.dst.port for c in incoming), sizes)


def _terminate_on_sigterm() -> None:
    """SIGTERM ends the node like Ctrl-C: results so far are saved, DDS entities deleted."""

    def handler(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)


class Node:
    """The node of one component; :meth:`run` returns the process exit code."""

    def __init__(
        self, system: CompiledSystem, plan: Ros2Plan, component: str, options: NodeOptions
    ) -> None:
        if component not in {c.name for c in system.components}:
            names = ", ".join(c.name for c in system.components)
            msg = f"the system has no component `{component}` (it has {names})"
            raise NodeError(msg)
        if component in plan.external:
            msg = f"component `{component}` is `external: true`: its topics come from outside"
            raise NodeError(msg)
        simulator = clock_source(system, plan)
        if options.clock_source and simulator is not None:
            msg = f"--clock-source: the simulator `{simulator}` publishes /clock in this system"
            raise NodeError(msg)
        self.system = system
        self.plan = plan
        self.component = system.component(component)
        self.node_plan: NodePlan = plan.node(component)
        self.options = options
        self.clock = StepClock(system.run, plan.distro)
        self.position = system.order.index(component)
        self.is_clock_source = options.sync is SyncMode.FREE and (
            simulator == component or options.clock_source
        )
        #: When this node began waiting for ``/clock``; settled once a sample came or the
        #: silence was logged (:meth:`_clock_silence`).
        self._clock_wait: float | None = None
        self._clock_settled = False
        self.steps_done = 0
        #: The step from which the model asked to end the simulation (None: it did not).
        self.ending_step: int | None = None
        self.inboxes: list[Inbox] = []
        self.outboxes: list[Outbox] = []
        self.transfers: tuple[Transfer, ...] = ()
        #: This node's component as the stepping core's work (set once its recording is).
        self.work: Work | None = None
        self.recording: NodeRecording | None = None
        self.runner: Runner | None = None
        self.remap = dict(options.remap)
        #: Stopwatches on the component's phases (``--profile``), else None.
        self.profile = Profile() if options.profile else None
        #: ``--on-nonfinite warn``: the non-finite values passed on, else None (a fault).
        self.nonfinite = NonFiniteWatch() if options.on_nonfinite == "warn" else None
        #: Seconds spent stepping (from the first step on) and, of them, waiting for inputs
        #: and publishing (a profiled node's ``other``).
        self._stepping = [0.0, 0.0]

    # -- set-up --------------------------------------------------------------------------------

    def _qos(self, profile: QosProfile, *, reader: bool, in_run: bool) -> QosProfile:
        """The QoS of one end of a data topic.

        Topics published inside the run are TRANSIENT_LOCAL on both ends: a reader that matches
        after the writer's first sample (matching order across processes is not defined, and a
        foreign reader can satisfy a writer's wait) still gets it. ROS 2 subscribers asking for
        VOLATILE still match. Lockstep also makes them RELIABLE and lets readers keep every
        sample: a lockstep reader counts samples and must never miss one. A free-run reader
        keeps 64 (a node descheduled for a moment must not lose the sample of its next step
        from the middleware's cache: 10 samples are 20 ms of a 500 Hz ``/odom``).
        """
        if not in_run:
            return profile
        if self.options.sync is not SyncMode.LOCKSTEP:
            depth = max(profile.depth, 64) if reader else profile.depth
            return QosProfile(profile.reliability, Durability.TRANSIENT_LOCAL, depth)
        return QosProfile(
            Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, max(profile.depth, 64), reader
        )

    def _open(self, participant: NodeTransport, runner: Runner) -> None:
        system, plan, name = self.system, self.plan, self.component.name
        distro = plan.distro
        schedules = topic_schedules(system, plan)
        scale = StepScale(system.run.start, system.run.step, system.run.steps)
        proxies: dict[str, ProxyRunner] = {}
        transfers = []
        for connection in system.inputs_of(name):
            src = connection.src.component
            proxy = proxies.setdefault(src, ProxyRunner(system.component(src)))
            transfers.append(make_transfer(connection, proxy, runner, watch=self.nonfinite))
        self.transfers = tuple(transfers)
        for topic_name in self.node_plan.subscribes:
            topic = plan.topic(topic_name)
            sinks: dict[tuple[str, str], tuple[str, Buffer]] = {}
            for sub in plan.subscriptions:
                if sub.component != name or sub.topic != topic_name:
                    continue
                if sub.connection_index < 0:  # a topic mapped onto one of this node's inputs
                    buffer = runner.input_buffer(sub.src_port)
                    sinks[("", sub.src_port)] = (sub.src_port, buffer)
                else:
                    source = system.connections[sub.connection_index].src.component
                    buffer = proxies[source].output_buffer(sub.src_port)
                    sinks[(source, sub.src_port)] = (sub.src_port, buffer)
            qos = self._qos(topic.qos, reader=True, in_run=topic.publisher is not None)
            reader = participant.reader(self._dds_name(topic_name), topic.msgtype, qos)
            codec = TopicCodec(topic.msgtype, topic.fields, distro, frame_id=topic.frame_id)
            schedule = schedules.get(topic_name) if topic.publisher is not None else None
            inbox = Inbox(topic, reader, codec, schedule, list(sinks.values()))
            if self.options.sync is SyncMode.FREE:
                inbox.stamped = StampedInput(self._match(topic), scale)
            self.inboxes.append(inbox)
        for topic_name in self.node_plan.publishes:
            topic = plan.topic(topic_name)
            writer = participant.writer(
                self._dds_name(topic_name), topic.msgtype,
                self._qos(topic.qos, reader=False, in_run=True),
            )  # fmt: skip
            codec = TopicCodec(topic.msgtype, topic.fields, distro, frame_id=topic.frame_id)
            values = {f.port: runner.output_buffer(f.port) for f in topic.fields}
            lazy = tuple(f.port for f in topic.fields if f.port in runner.lazy_outputs)
            readers = len({s.component for s in plan.subscriptions if s.topic == topic_name})
            self.outboxes.append(
                Outbox(topic, writer, codec, schedules[topic_name], values, lazy, readers)
            )

    def _work(self, runner: Runner) -> Work:
        """The component's step for the stepping core: its transfers, its recorded tracks
        (timed by phase with ``--profile``)."""
        recording, name = self.recording, self.component.name
        work = Work(
            name, self.transfers, runner.step,
            self.component.period_steps * self.system.run.step,
            None if recording is None else recording.before,
            None if recording is None else recording.after, (name,),
        )  # fmt: skip
        if self.profile is not None:
            work = self.profile.timed(work, getattr(runner, "step_phase", "step"))
        return work

    def _dds_name(self, topic_name: str) -> str:
        """The DDS name of a plan topic after ``--remap``."""
        return dds_topic(self.remap.get(topic_name, topic_name))

    def _match(self, topic: TopicPlan) -> Match:
        """How a free-run inbox stamps its samples: header, source timestamp, or arrival."""
        if topic.publisher is None:
            return Match.ARRIVAL
        if starts_with_header(topic.msgtype, self.plan.distro):
            return Match.HEADER
        return Match.SOURCE

    def input_counts(self) -> dict[str, dict[str, str | int]]:
        """Free run: per subscribed topic, what :class:`StampedInput` counted."""
        return {
            box.topic.name: box.stamped.finish().as_json()
            for box in self.inboxes
            if box.stamped is not None
        }

    def _readers_matched(self) -> None:
        for box in self.outboxes:
            if not box.writer.wait_for_readers(box.readers, MATCH_TIMEOUT):
                log.warning(
                    "topic %s: only %d of %d readers matched",
                    box.topic.name,
                    box.writer.matched(),
                    box.readers,
                )

    # -- stepping ------------------------------------------------------------------------------

    def _publish(self, runner: Runner, n: int | None, stamp: float) -> None:
        for box in self.outboxes:
            due = box.schedule.published_at_init() if n is None else box.schedule.published_at(n)
            if not due:
                continue
            for port in box.lazy:
                if self.profile is None:
                    runner.produce(port)
                else:
                    self.profile.render(self.component.name, partial(runner.produce, port))()
            box.writer.write(box.codec.encode(box.values, stamp), round(stamp * 1e9))

    def _step(self, runner: Runner, n: int, *, exact: bool) -> None:
        if self.profile is None:
            self._exchange_and_step(runner, n, exact=exact)
            return
        began = time.perf_counter()
        busy = self.profile.entry(self.component.name).busy
        try:
            self._exchange_and_step(runner, n, exact=exact)
        finally:
            took = time.perf_counter() - began
            self._stepping[0] += took
            self._stepping[1] += took - (self.profile.entry(self.component.name).busy - busy)

    def _exchange_and_step(self, runner: Runner, n: int, *, exact: bool) -> None:
        t = self.system.run.time_at(n)
        if not exact:
            self._gather(n, t)
        else:
            for inbox in self.inboxes:
                if inbox.schedule is not None:
                    inbox.exact(inbox.schedule.count_before(n, self.position))
                else:
                    inbox.newest()
        work = self.work
        assert work is not None
        try:
            work.perform(t)  # the stepping core, as in-process: feed, record, step, record
        except ModelTerminated:  # the step completed: its outputs are the last row
            self.steps_done = n + self.component.period_steps
            self.ending_step = n
            raise
        self.steps_done = n + self.component.period_steps
        self._publish(runner, n, t + work.h)

    def _gather(self, n: int, t: float) -> None:
        """Free run: load each input's sample of step ``n``, waiting at most ``input_wait``.

        The clock source (the simulator) never waits: it is the physical world, and its inputs
        are as late as the loop through the other nodes makes them (its stale count says how
        often).
        """
        wait = 0.0 if self.is_clock_source else self.options.input_wait
        level = logging.INFO if self.is_clock_source else logging.WARNING  # stale is normal there
        deadline = time.monotonic() + wait
        expected = [inbox.expected(n, self.position) for inbox in self.inboxes]
        for inbox, stamp in zip(self.inboxes, expected, strict=True):
            inbox.settle(stamp, deadline)
        for inbox, stamp in zip(self.inboxes, expected, strict=True):
            inbox.load(stamp, t, level)

    # -- time ----------------------------------------------------------------------------------

    def _latest_tick(self, reader: SampleReader, timeout: float) -> int | None:
        if self._clock_wait is None:
            self._clock_wait = time.monotonic()
        latest: int | None = None
        while True:
            samples = reader.take(256)
            for data in samples:
                tick = self.clock.decode(data)
                latest = tick if latest is None else max(latest, tick)
            if len(samples) < 256:
                break
        if latest is None and reader.wait(timeout):
            return self._latest_tick(reader, 0.0)
        self._clock_silence(latest)
        return latest

    def _clock_silence(self, tick: int | None) -> None:
        """Say once, after :data:`CLOCK_SILENCE` seconds without any ``/clock`` sample, that the
        node waits for one and who sends it: a node started alone (or from a launch file of a
        system without a simulator) otherwise waited in silence for ever."""
        if self._clock_settled or tick is not None:
            self._clock_settled = True
            return
        assert self._clock_wait is not None  # set by the first _latest_tick
        if time.monotonic() - self._clock_wait >= CLOCK_SILENCE:
            self._clock_settled = True
            sender = (
                "in lockstep, the supervisor of `fmionnx run --backend ros2` sends it"
                if self.options.sync is SyncMode.LOCKSTEP
                else "in a free run, the simulator's node sends it; a system without a "
                "simulator needs one node started with --clock-source, as `fmionnx ros2 "
                "launch-file` writes it"
            )
            log.warning("no /clock sample in %g s, still waiting: %s", CLOCK_SILENCE, sender)

    def _lockstep(self, runner: Runner, clock: SampleReader, done: SampleWriter) -> None:
        total, period = self.system.run.steps, self.component.period_steps
        name = self.component.name
        while True:
            n = self._latest_tick(clock, 1.0)
            if n is None:
                continue
            if n >= total:
                return
            if n % period:
                continue
            self._step(runner, n, exact=True)
            done.write(self.clock.encode_done(name, n))

    def _free(self, runner: Runner, clock: SampleReader) -> None:
        total, period = self.system.run.steps, self.component.period_steps
        next_n, started, now = 0, False, 0
        while next_n < total:
            tick = self._latest_tick(clock, 1.0)
            if tick is not None:
                now = max(now, tick)
            if not started:
                for inbox in self.inboxes:
                    inbox.collect()
                started = all(inbox.received > 0 for inbox in self.inboxes)
                if not started:
                    if now >= total:
                        return
                    continue
                log.info(
                    "every input arrived; stepping from t=%g s", self.system.run.time_at(next_n)
                )
            while next_n < min(now, total):
                self._step(runner, next_n, exact=False)
                next_n += period

    def _free_clock_source(
        self, runner: Runner, clock_in: SampleReader, clock_out: SampleWriter
    ) -> None:
        run, period = self.system.run, self.component.period_steps
        total = run.steps
        if self.options.supervised:
            while self._latest_tick(clock_in, 1.0) is None:
                pass
        started = time.perf_counter()
        rtf = self.options.rtf
        for n in range(0, total, period):
            if rtf > 0:
                wait = started + (n * run.step) / rtf - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
            self._step(runner, n, exact=False)
            clock_out.write(self.clock.encode(min(n + period, total)))

    # -- the process ---------------------------------------------------------------------------

    def run(self) -> int:
        """Run to the end of the simulation; 0 when completed, 1 on a fault, 130 when stopped,
        :data:`ENDED_BY_MODEL` when the model ended the simulation."""
        _terminate_on_sigterm()
        opts = self.options
        status, error, code = "completed", None, 0
        ended: dict[str, str | float | int] | None = None
        participant = open_transport(
            opts.middleware, from_environment(self.plan.distro), self.node_plan.namespace,
            self.node_plan.name, zenoh_router=opts.zenoh_router,
        )  # fmt: skip
        announcer: GraphAnnouncer | None = None
        runner = make_runner(self.component, _wiring(self.system, self.component))
        self.runner = runner
        name, profile = self.component.name, self.profile
        try:
            if profile is None:
                runner.instantiate()
                runner.setup(self.system.run.start, self.system.run.stop)
            else:
                profile.entry(name, step_phase=getattr(runner, "step_phase", "step"))
                profile.timed_once(name, "instantiate", runner.instantiate)
                setup = partial(runner.setup, self.system.run.start, self.system.run.stop)
                profile.timed_once(name, "initialize", setup)
            self._open(participant, runner)
            clock_in = participant.reader(CLOCK_DDS, CLOCK_TYPE, CONTROL_READER_QOS)
            done = participant.writer(DONE_DDS, DONE_TYPE, CONTROL_WRITER_QOS)
            ready = participant.writer(READY_DDS, READY_TYPE, CONTROL_WRITER_QOS)
            clock_out = None
            if self.is_clock_source:
                clock_out = participant.writer(CLOCK_DDS, CLOCK_TYPE, CONTROL_WRITER_QOS)
            if isinstance(participant, Participant):  # rclpy announces its nodes itself
                readers = [*(b.reader for b in self.inboxes), clock_in]
                writers = [*(b.writer for b in self.outboxes), clock_out, done, ready]
                announcer = GraphAnnouncer(participant)
                announcer.add_node(
                    NodeEntities(
                        self.node_plan.namespace, self.node_plan.name,
                        [r.gid for r in readers if isinstance(r, RawReader)],
                        [w.gid for w in writers if isinstance(w, RawWriter)],
                    )
                )  # fmt: skip
            self._readers_matched()
            evaluate_at_start(  # ONNX: outputs at the start time from the start inputs
                runner, self.inboxes, self.transfers, self.system.run.start,
                lockstep=opts.sync is SyncMode.LOCKSTEP,
            )  # fmt: skip
            self.recording = node_recording(self.system, runner, record_refs(self.system))
            self.work = self._work(runner)
            self._publish(runner, None, self.system.run.start)
            if opts.supervised:
                ready.wait_for_readers(1, MATCH_TIMEOUT)
                done.wait_for_readers(1, MATCH_TIMEOUT)
                ready.write(encode_ready(self.component.name, self.plan.distro))
            log.info(
                "node %s (%s) ready, sync %s, ROS 2 %s",
                self.node_plan.fqn,
                self.component.name,
                opts.sync.value,
                self.plan.distro.value,
            )
            if opts.sync is SyncMode.LOCKSTEP:
                self._lockstep(runner, clock_in, done)
            elif clock_out is not None:
                self._free_clock_source(runner, clock_in, clock_out)
            else:
                self._free(runner, clock_in)
            log.info("finished at step %d", self.steps_done)
        except ModelTerminated as exc:
            # The model ended the simulation (FMI terminateSimulation): no fault, but the
            # other nodes must stop too; the supervisor reads who and when from the status.
            ended = self._ended(exc)
            status, code = "ended", ENDED_BY_MODEL
            log.info("the model ended the simulation at t=%g s: %s", ended["time"], exc.reason)
        except RunError as exc:
            status, error, code = "fault", exc, 1
            log.error("fault: %s", exc)  # noqa: TRY400 - the fault is the message, not a bug
        except KeyboardInterrupt:
            status, code = "interrupted", 130
            log.info("stopped at step %d", self.steps_done)
        finally:
            if opts.record_dir is not None:
                inputs = self.input_counts() if opts.sync is SyncMode.FREE else None
                save_node(opts.record_dir, self.recording, self.component.name,
                          status=status, steps=self.steps_done, error=error, inputs=inputs,
                          ended=ended, statistics=self._statistics(),
                          warnings=self.nonfinite.messages() if self.nonfinite else None)  # fmt: skip
            runner.terminate()
            if announcer is not None:
                announcer.withdraw()
            participant.close()
        return code

    def _statistics(self) -> dict[str, Detail] | None:
        """A profiled node's statistics: its component's entry against the node's own time
        spent stepping, and, beside it, what of that went to exchanging samples (waiting for
        inputs, decoding, publishing)."""
        if self.profile is None:
            return None
        stepping, exchanging = self._stepping
        report = self.profile.report(stepping)
        report["other"] = {"exchange": round(exchanging, 6)}
        return report

    def _ended(self, request: ModelTerminated) -> dict[str, str | float | int]:
        """The status file's ``ended_by``: as the in-process master words it, plus ``step``
        (the base step the ending step started from). The run ends at the end of that step,
        at the stop time at the latest."""
        run = self.system.run
        n = self.ending_step if self.ending_step is not None else self.steps_done
        end = min(n + self.component.period_steps, run.steps)
        return {
            "component": request.component or self.component.name,
            "time": run.start + end * run.step,
            "reason": request.reason,
            "step": n,
        }


def describe_node(plan: Ros2Plan, component: str) -> str:
    """``fmu_sign_tracking_node (tracker)`` for messages."""
    try:
        return f"{plan.node(component).fqn} (component `{component}`)"
    except KeyError:
        return f"component `{component}`"
