"""``fmionnx run --backend ros2``: one OS process per component, owned by this supervisor.

Children are ``python -m fmionnx node SYSTEM COMPONENT --supervised ...``, each in its own
process group (the supervisor, not the terminal, decides when they stop) and with
``PR_SET_PDEATHSIG`` so that they die with the supervisor even when it is killed outright.
stdout and stderr of each go to ``<out>/logs/<component>.log``; each node saves its recorded
rows under ``<out>/nodes/`` when it ends, and the supervisor merges them into the usual
:class:`RunResult` (so ``results.csv``/``run.json`` are written by :mod:`fmionnx.results`).

Lockstep hand-shake (``docs/ros2.md``): wait for ``/fmionnx/ready`` from every node, then for
``n = 0 .. N-1`` publish ``/clock = t_n`` and wait for ``/fmionnx/done`` (stamp ``t_n``) from
every node due at ``n``; finally publish ``t_N``, on which every node saves and exits. Free run:
publish ``t_0`` once as the start signal; the simulator node then publishes ``/clock``.

Any child ending early stops the run: a node that reported a fault gives a FAULT result with its
error; a node whose model ended the simulation (exit status :data:`ENDED_BY_MODEL`) ends it
normally, ``ended_by`` that component, as in-process (:meth:`Supervisor._model_end`); any other
exit is a crash, reported with the node's name, exit status and last log lines.
Ctrl-C / SIGTERM stop every child (SIGTERM, then SIGKILL after a grace period).
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.backends.ros2.bag import TopicRecorder
from fmionnx.backends.ros2.control import (
    CLOCK_DDS,
    CONTROL_READER_QOS,
    CONTROL_WRITER_QOS,
    DONE_DDS,
    DONE_TYPE,
    READY_DDS,
    READY_TYPE,
    StepClock,
    decode_ready,
)
from fmionnx.backends.ros2.discovery import GraphAnnouncer, NodeEntities
from fmionnx.backends.ros2.env import DdsEnvironment, from_environment
from fmionnx.backends.ros2.loading import plan_for, resolve_distro
from fmionnx.backends.ros2.middleware import NodeTransport, SampleReader, SampleWriter
from fmionnx.backends.ros2.node import (
    ENDED_BY_MODEL,
    INPUT_WAIT,
    SyncMode,
    clock_source,
    describe_node,
)
from fmionnx.backends.ros2.recording import (
    error_of,
    issued_before,
    load_status,
    merge,
    record_refs,
)
from fmionnx.backends.ros2.transport import Participant, RawReader, RawWriter
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.plan import CLOCK_TYPE
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.compile.systemfile import SUFFIX as COMPILED_SUFFIX
from fmionnx.compile.systemfile import write_compiled
from fmionnx.core.errors import FmionnxError, RunError
from fmionnx.core.safewrite import open_growing
from fmionnx.core.scratch import scratch
from fmionnx.runtime.result import Detail, EndedBy, RunOptions, RunResult, RunStatus
from fmionnx.runtime.stopping import late_stop_text, stop_on_signals, stop_reason, stops_held

if TYPE_CHECKING:
    from fmionnx.backends.ros2.zenoh.router import RouterChoice

BACKEND_NAME = "ros2"
#: Name under which the supervisor itself shows in ``ros2 node list``.
SUPERVISOR_NODE = "fmionnx_supervisor"
#: Name under which ``--record``'s readers show (rosbag2 calls its node ``rosbag2_recorder``).
RECORDER_NODE = "fmionnx_recorder"
#: Log lines quoted when a node crashes.
TAIL_LINES = 12
#: Seconds children get to save their results after SIGTERM before SIGKILL.
GRACE = 10.0


class SupervisorError(FmionnxError):
    """The run could not go on: a node never became ready, or hung in a lockstep step."""


@dataclass(frozen=True)
class Ros2Options:
    """What ``fmionnx run --backend ros2`` passes on to its nodes.

    Every node starts from the supervisor's compiled system (overrides applied, plan for
    ``distro`` included), written to ``<out>/system.fmionnx.json``: no node compiles anything.
    ``distro`` None: the system's own (its ``ros2: distro:``, else the default); given, it
    overrides the system file (``--ros-distro``).
    ``out``: that file, logs and node rows go to ``out/logs`` and ``out/nodes`` (a temporary
    folder without it).
    """

    sync: SyncMode = SyncMode.LOCKSTEP
    distro: RosDistro | None = None
    out: Path | None = None
    rtf: float = 1.0
    ready_timeout: float = 180.0
    #: Lockstep: seconds a step may take before the nodes still busy with it are named.
    step_timeout: float = 60.0
    #: Also record every topic into this MCAP file (``--record``).
    record: Path | None = None
    #: ``rclpy``: every node runs through rclpy (the supervisor stays on Cyclone DDS);
    #: ``zenoh``: every node and the supervisor speak the rmw_zenoh wire.
    middleware: str = "dds"
    #: Free run: seconds a node's step waits for an input sample of its time (``--input-wait``).
    input_wait: float = INPUT_WAIT
    #: ``zenoh``: ``auto`` (a reachable router, else one started in-process) or an endpoint.
    zenoh_router: str = "auto"
    run: RunOptions = field(default_factory=RunOptions)


class NodeEnded(Exception):  # noqa: N818 - a control-flow signal, not an error type
    """A child process ended before the run did."""

    def __init__(self, component: str, code: int) -> None:
        self.component = component
        self.code = code
        super().__init__(component)


def _die_with_parent() -> None:  # pragma: no cover - runs in the forked child
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def exit_text(code: int) -> str:
    """``exited with status 3`` / ``was killed by signal 9 (SIGKILL)``."""
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = "?"
        return f"was killed by signal {-code} ({name})"
    return f"exited with status {code}"


#: Seconds every node has, once the clock reached the stop time, to end by itself.
FINISH_SECONDS = 60.0


def not_ended_message(components: list[str]) -> str:
    """Why a run faulted when nodes did not end after the stop time, naming them (a node that
    logged "finished" and still did not exit hung in its own shutdown: its log says which)."""
    named = ", ".join(f"`{c}` (logs/{c}.log)" for c in components) or "none named"
    return f"nodes did not end within {FINISH_SECONDS:g} s after the stop time: {named}"


def tail(path: Path, lines: int = TAIL_LINES) -> str:
    """The last ``lines`` lines of a log file (empty when unreadable)."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return ""
    return "\n".join(text.splitlines()[-lines:])


class Children:
    """The node processes: started, polled, stopped; never left behind."""

    def __init__(self, logs: Path) -> None:
        self.logs = logs
        self.procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(self, component: str, argv: list[str]) -> None:
        """Start one node, output to ``logs/<component>.log``, in a process group of its own."""
        self.logs.mkdir(parents=True, exist_ok=True)
        with open_growing(self.logs / f"{component}.log") as log:
            self.procs[component] = subprocess.Popen(
                argv,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                process_group=0,
                preexec_fn=_die_with_parent,  # noqa: PLW1509 - only prctl, no locks
            )

    def check(self) -> None:
        """Raise :class:`NodeEnded` for the first child that is no longer running."""
        for component, proc in self.procs.items():
            code = proc.poll()
            if code is not None:
                raise NodeEnded(component, code)

    def running(self) -> list[str]:
        """The components whose node process has not ended, in start order."""
        return [component for component, proc in self.procs.items() if proc.poll() is None]

    def ended_cleanly(self, records: Path) -> bool:
        """True when every child ended after completing; NodeEnded for any other ending."""
        running = False
        for component, proc in self.procs.items():
            code = proc.poll()
            if code is None:
                running = True
                continue
            status = load_status(records, component) or {}
            if code != 0 or status.get("status") != "completed":
                raise NodeEnded(component, code)
        return not running

    def wait_all(self, timeout: float) -> bool:
        """Wait until every child ended; False on timeout."""
        deadline = time.monotonic() + timeout
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(deadline - time.monotonic(), 0.01))
            except subprocess.TimeoutExpired:
                return False
        return True

    def stop(self) -> None:
        """SIGTERM every process group, SIGKILL what is left after :data:`GRACE` seconds."""
        for proc in self.procs.values():
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGTERM)
                    os.killpg(proc.pid, signal.SIGCONT)  # a stopped (hung) node must see it
        if not self.wait_all(GRACE):
            for proc in self.procs.values():
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
            self.wait_all(GRACE)
        for proc in self.procs.values():  # sub-processes a node left in its group
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)


class Supervisor:
    """One run of a system as ROS 2 nodes."""

    def __init__(self, system: CompiledSystem, options: Ros2Options, folder: Path) -> None:
        self.system = system
        self.options = options
        #: The distribution of the run: ``--ros-distro``, else the system file's.
        self.distro: RosDistro = resolve_distro(system, options.distro)
        self.plan: Ros2Plan = plan_for(system, self.distro)
        self.folder = folder
        #: What every node starts from (written when the run starts).
        self.compiled_file = folder / f"system{COMPILED_SUFFIX}"
        self.records = folder / "nodes"
        self.logs = folder / "logs"
        self.children = Children(self.logs)
        self.clock = StepClock(system.run, self.distro)
        self.components = [n.component for n in self.plan.nodes]
        self.steps_done = 0
        #: Lockstep: the nodes due at the current step that did not report it done yet.
        self.pending: set[str] = set()
        #: A model ended the simulation: who, when (as in-process), and the rows to keep.
        self.ended_by: EndedBy | None = None
        self.issued: dict[str, int] | None = None
        self.recorder: TopicRecorder | None = None
        self.domain_id = 0
        #: ``--middleware zenoh``: the router the run uses (chosen when it starts).
        self.router: RouterChoice | None = None

    def argv(self, component: str) -> list[str]:
        """The command line of one node."""
        opts = self.options
        argv = [
            sys.executable, "-m", "fmionnx", "node", str(self.compiled_file), component,
            "--sync", opts.sync.value, "--ros-distro", self.distro.value,
            "--record-dir", str(self.records), "--supervised", "--rtf", repr(opts.rtf),
        ]  # fmt: skip
        if opts.middleware != "dds":
            argv += ["--middleware", opts.middleware]
        if opts.input_wait != INPUT_WAIT:
            argv += ["--input-wait", repr(opts.input_wait)]
        if self.router is not None:
            argv += ["--zenoh-router", self.router.endpoint]
        if opts.run.profile:
            argv.append("--profile")
        if opts.run.on_nonfinite != "fault":
            argv += ["--on-nonfinite", opts.run.on_nonfinite]
        return argv

    # -- phases --------------------------------------------------------------------------------

    def _wait_ready(self, ready: SampleReader) -> None:
        waiting = set(self.components)
        deadline = time.monotonic() + self.options.ready_timeout
        while waiting:
            self.children.check()
            if time.monotonic() > deadline:
                names = ", ".join(sorted(waiting))
                msg = f"node(s) {names} did not become ready in {self.options.ready_timeout:g} s"
                raise SupervisorError(msg)
            for data in ready.take():
                waiting.discard(decode_ready(data, self.distro))
            ready.wait(0.2)

    def _wait_for_clock_readers(self, writer: SampleWriter, timeout: float = 30.0) -> None:
        """Every node's clock reader, plus the supervisor's own, matched; a node that ends
        meanwhile stops the wait at once (its reader would never come)."""
        deadline = time.monotonic() + timeout
        while not writer.wait_for_readers(len(self.components) + 1, 0.2):
            self.children.check()
            if time.monotonic() > deadline:
                return

    def _progress(self, n: int) -> None:
        progress = self.options.run.progress
        if progress is not None and n % max(1, self.options.run.progress_every) == 0:
            run = self.system.run
            progress(n, run.steps, run.time_at(n))

    def _lockstep(self, writer: SampleWriter, done: SampleReader) -> None:
        system = self.system
        periods = {c: system.component(c).period_steps for c in self.components}
        total = system.run.steps
        for n in range(total):
            writer.write(self.clock.encode(n))
            due = self.pending = {c for c, p in periods.items() if n % p == 0}
            deadline = time.monotonic() + self.options.step_timeout
            while due:
                for data in done.take(256):
                    component, step = self.clock.decode_done(data)
                    if step == n:
                        due.discard(component)
                if due and not done.wait(0.2):
                    self.children.check()
                    if time.monotonic() > deadline:
                        raise SupervisorError(self._hung(due, n))
            self.steps_done = n + 1
            self._progress(n + 1)
        writer.write(self.clock.encode(total))

    def _hung(self, busy: set[str], n: int) -> str:
        """The error for nodes that did not finish step ``n`` within the step timeout."""
        names = ", ".join(describe_node(self.plan, c) for c in sorted(busy))
        message = (
            f"lockstep step {n} (t = {self.system.run.time_at(n):g} s) did not finish within "
            f"{self.options.step_timeout:g} s: still waiting for {names}"
        )
        for component in sorted(busy):
            lines = tail(self.logs / f"{component}.log", 5)
            if lines:
                message += f"\nlast log lines of {component}:\n{lines}"
        return message + "\n(raise the limit with --step-timeout if a step is legitimately slow)"

    def _free(self, clock_writer: SampleWriter, clock: SampleReader) -> None:
        clock_writer.write(self.clock.encode(0))
        total = self.system.run.steps
        step = self.system.run.step
        own_clock = clock_source(self.system, self.plan) is None
        started = time.perf_counter()
        rtf = self.options.rtf
        n = 0
        while True:
            if own_clock and n < total:
                target = started + (n * step / rtf if rtf > 0 else 0.0)
                time.sleep(max(0.0, min(target - time.perf_counter(), 0.05)))
                if time.perf_counter() >= target:
                    n += 1
                    clock_writer.write(self.clock.encode(n))
            else:
                clock.wait(0.2)
            for data in clock.take(256):
                n = max(n, self.clock.decode(data))
            if n > self.steps_done:
                self.steps_done = min(n, total)
                self._progress(self.steps_done)
            if self.children.ended_cleanly(self.records):
                return

    # -- the run -------------------------------------------------------------------------------

    def run(self) -> RunResult:
        """Start the nodes, drive or watch the clock, stop everything, merge the results."""
        status, error = RunStatus.COMPLETED, None
        self.interrupted_by: str | None = None
        write_compiled(dataclasses.replace(self.system, ros2_plan=self.plan), self.compiled_file)
        env = from_environment(self.distro)
        self.domain_id = env.domain_id
        participant = self._open_transport(env)
        started = time.perf_counter()
        wall_start = started
        done: SampleReader | None = None
        try:
            self._refuse_loops()
            ready = participant.reader(READY_DDS, READY_TYPE, CONTROL_READER_QOS)
            done = participant.reader(DONE_DDS, DONE_TYPE, CONTROL_READER_QOS)
            clock_writer = participant.writer(CLOCK_DDS, CLOCK_TYPE, CONTROL_WRITER_QOS)
            clock_reader = participant.reader(CLOCK_DDS, CLOCK_TYPE, CONTROL_READER_QOS)
            if self.options.record is not None:
                self.recorder = TopicRecorder(self.options.record, self.plan, participant)
            if isinstance(participant, Participant):  # the Zenoh graph comes from its tokens
                self._announce(participant, [ready, done, clock_reader], clock_writer)
            self.records.mkdir(parents=True, exist_ok=True)
            for stale in [*self.records.glob("*.npz"), *self.records.glob("*.json")]:
                stale.unlink()
            for component in self.components:
                self.children.start(component, self.argv(component))
            self._wait_ready(ready)
            self._wait_for_clock_readers(clock_writer)
            wall_start = time.perf_counter()
            if self.options.sync is SyncMode.LOCKSTEP:
                self._lockstep(clock_writer, done)
            else:
                self._free(clock_writer, clock_reader)
            self._finish()
        except NodeEnded as ended:
            status, error = self._node_ended(ended, done)
        except SupervisorError as exc:
            status, error = RunStatus.FAULT, RunError(str(exc))
        except KeyboardInterrupt as exc:
            status, self.interrupted_by = RunStatus.INTERRUPTED, stop_reason(exc)
        finally:
            wall = time.perf_counter() - wall_start
            # From here on a stop signal cuts nothing off: the nodes stopped, the recording
            # closed (its footer written), their rows merged (runtime.stopping.stops_held).
            with stops_held() as late:
                self._end(participant)
        with stops_held() as also_late:
            result = self._result(status, error, wall)
        for name in [*late, *also_late][:1]:
            result.warnings.append(late_stop_text(name))
        return result

    def _end(self, participant: NodeTransport) -> None:
        """Stop the nodes, close the recording, the transport and the router."""
        self.children.stop()
        if self.recorder is not None:
            self.recorder.close()
        participant.close()
        if self.router is not None:
            self.router.close()
        if self.options.middleware == "zenoh":  # what killed nodes left in /dev/shm
            from fmionnx.backends.ros2.zenoh.shm import remove_orphaned_segments

            remove_orphaned_segments()

    def _open_transport(self, env: DdsEnvironment) -> NodeTransport:
        """The supervisor's own endpoints: a Cyclone participant, or a Zenoh session (after
        choosing the router, started here when ``auto`` finds none)."""
        if self.options.middleware != "zenoh":
            return Participant(env)
        from fmionnx.backends.ros2.zenoh.config import zenoh_environment
        from fmionnx.backends.ros2.zenoh.router import choose_router
        from fmionnx.backends.ros2.zenoh.shm import remove_orphaned_segments
        from fmionnx.backends.ros2.zenoh.transport import ZenohTransport

        remove_orphaned_segments()  # what an earlier run, killed as a whole, left behind
        zenv = zenoh_environment(env.distro)
        self.router = choose_router(self.options.zenoh_router, zenv)
        try:
            return ZenohTransport(zenv.with_router(self.router.endpoint), "/", SUPERVISOR_NODE)
        except BaseException:
            self.router.close()
            raise

    def _announce(
        self, participant: Participant, readers: list[SampleReader], writer: SampleWriter
    ) -> None:
        """DDS: name the supervisor's (and the recorder's) endpoints on ros_discovery_info."""
        self.announcer = GraphAnnouncer(participant)  # kept alive: its writer is the sample
        reader_gids = [r.gid for r in readers if isinstance(r, RawReader)]
        writer_gids = [writer.gid] if isinstance(writer, RawWriter) else []
        self.announcer.add_node(NodeEntities("/", SUPERVISOR_NODE, reader_gids, writer_gids))
        if self.recorder is not None:
            gids = [t.reader.gid for t in self.recorder.topics if isinstance(t.reader, RawReader)]
            self.announcer.add_node(NodeEntities("/", RECORDER_NODE, gids, []))

    def _refuse_loops(self) -> None:
        """Iterated algebraic loops repeat their members' steps; a node steps once per point."""
        if self.system.loops:
            labels = "; ".join(loop.label for loop in self.system.loops)
            msg = (
                f"the system has algebraic loops solved by iteration ({labels}): their members "
                "must step in one process, which the ROS 2 backend does not do; run it in-process"
            )
            raise SupervisorError(msg)

    def _finish(self) -> None:
        """Every node must end by itself, cleanly, once the clock reached the stop time."""
        if not self.children.wait_all(FINISH_SECONDS):
            raise SupervisorError(not_ended_message(self.children.running()))
        self.children.ended_cleanly(self.records)

    def _node_ended(
        self, ended: NodeEnded, done: SampleReader | None
    ) -> tuple[RunStatus, RunError | None]:
        """A node ended before the run did: its model ending the simulation, else a fault."""
        try:
            if self._model_end(ended, done):
                return RunStatus.COMPLETED, None
        except NodeEnded as other:  # a node before it failed in the same step: that wins
            return RunStatus.FAULT, self._ended_error(other)
        except SupervisorError as exc:
            return RunStatus.FAULT, RunError(str(exc))
        return RunStatus.FAULT, self._ended_error(ended)

    def _end_request(self, component: str, code: int) -> dict[str, Any] | None:
        """The ``ended_by`` of a node that exited because its model ended the simulation."""
        if code != ENDED_BY_MODEL:
            return None
        status = load_status(self.records, component) or {}
        ended = status.get("ended_by")
        if status.get("status") != "ended" or not isinstance(ended, dict):
            return None
        return ended

    def _model_end(self, ended: NodeEnded, done: SampleReader | None) -> bool:
        """End the run as in-process when ``ended``'s model ended the simulation; False if not.

        In-process, the run ends at the end of that step: components before it in the order
        did their step at that time, those after it did not. Lockstep therefore waits until
        the nodes before it finished the step (one of them ending the run too takes over, as
        the earlier one in the order) and keeps no row of work the order would not have done
        (:func:`issued_before`); the other nodes are stopped like at Ctrl-C.
        """
        component, request = ended.component, self._end_request(ended.component, ended.code)
        if request is None:
            return False
        n = int(request["step"])
        if self.options.sync is SyncMode.LOCKSTEP and done is not None:
            component, request = self._settle_step(component, request, done)
            self.issued = issued_before(self.system, n, component, self.components)
        run = self.system.run
        self.steps_done = min(n + self.system.component(component).period_steps, run.steps)
        self.ended_by = EndedBy(
            str(request["component"]), run.start + self.steps_done * run.step,
            str(request["reason"]),
        )  # fmt: skip
        return True

    def _settle_step(
        self, component: str, request: dict[str, Any], done: SampleReader
    ) -> tuple[str, dict[str, Any]]:
        """Lockstep: wait for the nodes before ``component`` still busy with the ending step;
        the component that ends the run (the earliest in the order) and its request."""
        n = int(request["step"])
        order = self.system.order
        waiting = {c for c in self.pending if order.index(c) < order.index(component)}
        deadline = time.monotonic() + self.options.step_timeout
        while waiting:
            for data in done.take(256):
                finished, step = self.clock.decode_done(data)
                if step == n:
                    waiting.discard(finished)
            for other in sorted(waiting, key=order.index):
                code = self.children.procs[other].poll()
                if code is None:
                    continue
                earlier = self._end_request(other, code)
                if earlier is None or int(earlier["step"]) != n:
                    raise NodeEnded(other, code)
                component, request = other, earlier
                waiting = {c for c in waiting if order.index(c) < order.index(other)}
                break
            if waiting and not done.wait(0.2) and time.monotonic() > deadline:
                raise SupervisorError(self._hung(waiting, n))
        return component, request

    def _ended_error(self, ended: NodeEnded) -> RunError:
        node = describe_node(self.plan, ended.component)
        status = load_status(self.records, ended.component)
        if status is not None and status.get("status") == "fault":
            fault = error_of(status)
            if fault is not None:
                self.steps_done = min(self.steps_done, int(status.get("steps", 0)))
                return fault
        lines = tail(self.logs / f"{ended.component}.log")
        message = f"node {node} {exit_text(ended.code)}"
        if lines:
            message += f"; its last log lines:\n{lines}"
        return RunError(message, component=ended.component)

    def _result(self, status: RunStatus, error: RunError | None, wall: float) -> RunResult:
        n = self.steps_done
        refs = record_refs(self.system, self.options.run)
        recorder = merge(self.records, self.components, refs, self.system, self.issued)
        result = RunResult.after(
            self.system, BACKEND_NAME, status, n, wall, recorder.table(n), error, self._details(),
            self.interrupted_by, self.ended_by,
        )  # fmt: skip
        statuses = {c: load_status(self.records, c) or {} for c in self.components}
        for component, found in statuses.items():
            result.warnings.extend(f"node {component}: {w}" for w in found.get("warnings", ()))
        if self.options.run.profile:
            result.statistics = node_statistics(statuses, wall)
        return result

    def _inputs(self) -> dict[str, Detail]:
        """Free run: each node's input counts (from its status file), by component and topic."""
        found: dict[str, Detail] = {}
        for component in self.components:
            inputs = (load_status(self.records, component) or {}).get("inputs")
            if isinstance(inputs, dict):
                found[component] = inputs
        return found

    def _details(self) -> dict[str, Detail]:
        """How the run executed, for run.json's ``execution``."""
        opts = self.options
        free = opts.sync is SyncMode.FREE
        return {
            "sync": opts.sync.value,
            "ros_distro": self.distro.value,
            "ros_domain_id": self.domain_id,
            "nodes": ", ".join(n.fqn for n in self.plan.nodes),
            "external": ", ".join(self.plan.external) or None,
            "logs": str(self.logs) if opts.out is not None else None,
            "record": str(opts.record) if opts.record is not None else None,
            "recorded_messages": self.recorder.messages if self.recorder is not None else None,
            "input_wait": opts.input_wait if free else None,
            "inputs": self._inputs() if free else None,
            "middleware": opts.middleware,
            "zenoh_router": self.router.describe() if self.router is not None else None,
        }


def node_statistics(statuses: dict[str, dict[str, Any]], wall: float) -> dict[str, Detail]:
    """``--profile`` for ROS 2: each node's component entry (its share of the node's own time
    stepping), by share; ``other`` per node: what went to exchanging samples."""
    entries: list[tuple[str, dict[str, Detail]]] = []
    other: dict[str, Detail] = {}
    for component, status in statuses.items():
        found = status.get("statistics")
        if not isinstance(found, dict):
            continue
        for name, entry in (found.get("components") or {}).items():
            entries.append((name, {**entry, "node_stepping_time": found.get("loop_wall_time")}))
        other[component] = found.get("other")
    entries.sort(key=lambda item: item[1].get("share") or 0.0, reverse=True)  # type: ignore[arg-type,return-value]
    return {
        "loop_wall_time": round(wall, 6),
        "schedule": "one process per node",
        "concurrent": True,
        "components": dict(entries),
        "other": other,
    }


def run_ros2(system: CompiledSystem, options: Ros2Options | None = None) -> RunResult:
    """Run ``system`` as ROS 2 nodes (one process each) and return the merged results.

    Raises DiagnosticError when the system does not map onto ROS 2 (nothing is started).
    """
    opts = options or Ros2Options()
    with contextlib.ExitStack() as stack:
        if opts.out is not None:
            folder = opts.out
            folder.mkdir(parents=True, exist_ok=True)
        else:
            folder = stack.enter_context(scratch("ros2"))
        supervisor = Supervisor(system, opts, folder)
        stack.enter_context(stop_on_signals())
        return supervisor.run()
    msg = "unreachable"  # pragma: no cover - mypy: ExitStack may swallow exceptions
    raise AssertionError(msg)
