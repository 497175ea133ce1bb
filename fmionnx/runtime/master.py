"""The in-process co-simulation master: fixed base step, multi-rate, Gauss-Seidel order.

Semantics (``docs/running.md``): communication points are ``t_n = start + n*step`` (computed,
never accumulated). At ``t_n`` every component with ``n % period_steps == 0`` is *due*; due
components run in ``CompiledSystem.order``. A due component first receives its inputs: each
connection copies the producer's newest output (the value published by a producer that already
ran at ``t_n``, else its previous value: a slower component's outputs are held), applying the
element selection, ``factor*x+offset`` and the dtype conversion. Then it steps from ``t_n`` by
its period. Loops the compiler cut at non-feedthrough outputs therefore read the producer's
previous value. A NaN or an infinity leaving a producer on a connection stops the run
(``on_nonfinite="warn"``: noted and passed on; :mod:`.transfer`).

Everything (runners, buffers, transfers, the schedule over one hyperperiod, recorder tracks) is
prepared before the loop; the loop only calls prepared closures. Consecutive FMI 2
co-simulation FMUs of one period are stepped by one call into a small C kernel
(:mod:`.native`), with bit-identical results; ``FMIONNX_NATIVE=0`` keeps them in Python.

With the parallel schedule (the default, :mod:`.parallel`), the loop issues the same work in
the same order but hands the steps that may overlap the following work to worker threads
(lanes), joining each before any work that reads or steps its component: the values are
those of the sequential loop, bit for bit. A failure in a concurrent step is settled as the
sequential run would have met it (:meth:`Master._settle`).

Two options change how the loop is watched, never what it computes: ``profile`` builds the
works with stopwatches (:mod:`.profile`), and ``rtf`` paces the base steps to the wall clock
(:mod:`.pacing`, profiled too, to say where the time of an overrun went). Both ride on the
loop's progress call, so a run asking for neither runs the plain loop.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import sys
import threading
import time as _time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

from fmionnx.compile.ir import AlgebraicLoop, CompiledSystem
from fmionnx.core.errors import ModelTerminated, RunError
from fmionnx.core.runner import Buffer, Runner, RunnerFactory, Wiring, fault
from fmionnx.core.signals import column_names, every_output, is_image
from fmionnx.core.types import Causality, Component, PortRef, flat_index
from fmionnx.runtime.instruments import PLAIN
from fmionnx.runtime.native.grouping import NativeStatus, plan_native
from fmionnx.runtime.parallel import Footprint, Issue, Job, Lane, footprint, plan
from fmionnx.runtime.profile import Profile
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.result import EndedBy, ProgressCallback, RunOptions, RunResult, RunStatus
from fmionnx.runtime.startvalues import evaluate_at_start
from fmionnx.runtime.stepping import Work
from fmionnx.runtime.stopping import (
    exit_code,
    late_stop_text,
    shield_begin,
    shield_end,
    stop_reason,
    stops_held,
)
from fmionnx.runtime.transfer import NonFiniteWatch, make_transfer
from fmionnx.runtime.watchdog import Interrupter, Phase, PhaseWatch, Watchdog, overrun_text

if TYPE_CHECKING:
    from fmionnx.runtime.loops import IteratedLoop
    from fmionnx.runtime.native.bulk import BulkLoop
    from fmionnx.runtime.native.group import NativeGroup
    from fmionnx.runtime.pacing import Pacer

#: Largest hyperperiod (in base steps) for which the schedule is tabulated.
MAX_TABLE = 100_000

BACKEND_NAME = "inprocess"


def default_record(system: CompiledSystem) -> tuple[PortRef, ...]:
    """The compiler's default (:func:`fmionnx.core.signals.every_output`), for a system
    whose ``record`` is empty (``record: []``, or compiled by hand)."""
    return every_output(system.components)


def plot_refs(system: CompiledSystem) -> tuple[PortRef, ...]:
    """Signals the system's plots draw (they must be recorded to be plotted)."""
    return tuple(ref for plot in system.plots for ref in plot.refs)


def required_refs(system: CompiledSystem) -> tuple[PortRef, ...]:
    """Signals recorded whatever ``record`` says: what the plots draw and the checks measure."""
    return (*plot_refs(system), *(ref for check in system.checks for ref in check.refs))


class _StepFailedError(Exception):
    """A concurrent step raised: carries the step (its work, time and place) and the error."""

    def __init__(self, job: Job, error: BaseException) -> None:
        super().__init__(str(error))
        self.job = job
        self.error = error


class Master:
    """Prepares runners for a compiled system and runs the loop."""

    def __init__(
        self,
        system: CompiledSystem,
        options: RunOptions | None = None,
        runner_factory: RunnerFactory | None = None,
    ) -> None:
        if runner_factory is None:
            from fmionnx.kinds.registry import make_runner

            runner_factory = make_runner
        self.system = system
        self.options = options or RunOptions()
        instruments = self.options.instruments or PLAIN
        self.runners: dict[str, Runner] = {}
        self._clock = [0]
        #: The step under way, for the watchdog (one store per step in the loop).
        self._marker = instruments.marker()
        #: Times the steps, and loading, initializing and terminating too, in this process.
        self._watchdog: Watchdog | None = None
        if self.options.step_timeout is not None:
            self._watchdog = Watchdog(
                self.options.step_timeout, self._marker, (), self._abandon,
                Interrupter(self.runners),
            )  # fmt: skip
            clock = lambda: system.run.start + self._clock[0] * system.run.step  # noqa: E731
            runner_factory = PhaseWatch(self._watchdog, self._marker, clock).factory(runner_factory)
        if self.options.isolate:
            from fmionnx.runtime.isolated.factory import isolating_factory
            from fmionnx.runtime.isolated.proxy import IsolationSettings

            settings = IsolationSettings(self.options.step_timeout, self.options.sandbox)
            runner_factory = isolating_factory(runner_factory, self.options.isolate, settings)
        if instruments.runners is not None:
            runner_factory = instruments.runners(runner_factory)
        self.make_runner = runner_factory
        self.recorder = instruments.recorder()
        self._table: list[tuple[Work, ...]] = []
        self._fallback: list[tuple[Work, int]] = []
        self._hyper = 1
        self._tracks: dict[str, tuple[Track | None, Track | None]] = {}
        #: Steps done per component with lazy outputs, and the step each lazy port was made at.
        self._stamps: dict[str, int] = {}
        #: Whether FMI 2 co-simulation runs are stepped natively (set by ``prepare``).
        self.native = NativeStatus(used=False, reason="not prepared")
        #: The native groups by id of their work; the one that is the whole schedule, stepped
        #: many base steps per C call (:mod:`.native.bulk`), else None; and whether a bulk
        #: call is under way (for the watchdog, see :meth:`_abandon`).
        self._groups: dict[int, NativeGroup] = {}
        self._bulk: BulkLoop | None = None
        self._in_bulk = False
        #: Set when a model ended the run before its stop time (see :meth:`_end_by`).
        self.ended_by: EndedBy | None = None
        #: Who ends the run: the loop's thread (``loop``) or the watchdog abandoning it
        #: (``abandon``), decided once under the lock (:meth:`_end_here`, :meth:`_abandon`).
        self._ending = threading.Lock()
        self._ends: str | None = None
        self._started = _time.perf_counter()
        #: The iterated algebraic loops (set by ``prepare``; see :mod:`.loops`).
        self.loops: list[IteratedLoop] = []
        #: The parallel schedule (:mod:`.parallel`): the table of issues, empty when every
        #: step runs on the loop's thread, and the lanes (worker threads) it hands steps to.
        self._issues: list[tuple[Issue, ...]] = []
        self._lanes: list[Lane] = []
        #: (work, period) in execution order and each work's place in it.
        self._entry_list: list[tuple[Work, int]] = []
        self._entry_index: dict[int, int] = {}
        #: The concurrent step the loop is waiting for (for the watchdog's report).
        self._joining: Job | None = None
        #: Stopwatches on every phase (``profile``, and a paced run's), else None.
        self.profile = Profile() if self.options.profile or self.options.rtf > 0 else None
        #: ``on_nonfinite="warn"``: the non-finite values passed on, else None (a fault).
        self.nonfinite = NonFiniteWatch() if self.options.on_nonfinite == "warn" else None
        self._pacer: Pacer | None = None

    # -- preparation ---------------------------------------------------------------------------

    def prepare(self) -> None:
        """Instantiate and initialize every runner, wire connections, build the schedule."""
        system = self.system
        run = system.run
        profile = self.profile
        for component in self._making_order():
            if profile is None:
                self._make(component)
            else:
                profile.timed_once(component.name, "instantiate", partial(self._make, component))
        for component in system.components:  # back in the system's order, in place
            self.runners[component.name] = self.runners.pop(component.name)
            if profile is not None and component.name in profile.entries:
                profile.entries[component.name] = profile.entries.pop(component.name)
        for name in system.order:
            setup = partial(self.runners[name].setup, run.start, run.stop)
            if profile is None:
                setup()
            else:
                profile.timed_once(name, "initialize", setup)
        for name, runner in self.runners.items():
            if runner.lazy_outputs:
                self._stamps[name] = 0
        evaluate_at_start(system, self.runners, self._producer_hook)  # ONNX: outputs at start
        self._build_tracks()
        dues = {name: self._due(system.component(name)) for name in system.order}
        entries = self._entries(dues)
        periods = [p for _, p in entries]
        hyper = math.lcm(*periods) if periods else 1
        if hyper <= MAX_TABLE:
            self._hyper = hyper
            self._table = [tuple(due for due, p in entries if k % p == 0) for k in range(hyper)]
        else:
            self._hyper = 0
            self._fallback = entries
        self._entry_list = entries
        self._entry_index = {id(due): i for i, (due, _) in enumerate(entries)}
        for i, (due, _) in enumerate(entries):
            due.place, due.marker = i, self._marker
            for name in due.members or (due.name,):
                before, after = self._tracks.get(name, (None, None))
                for track in (before, after):
                    if track is not None:
                        track.place, track.outputs = i, track is after
        if self.options.schedule == "parallel" and self._hyper:
            self._plan_parallel(entries)
        self._bulk = self._plan_bulk()

    def _making_order(self) -> list[Component]:
        """The components in the system's order, those run in a child process last.

        An isolated component's child is forked by the zygote, which imports what children
        need (about half a second of CPU) from the start of :meth:`prepare`: made after the
        in-process models (a MuJoCo scene, an ONNX session), the first child waits for the
        zygote while those load instead of before. :attr:`runners` and the profile's entries
        are put back in the system's order. The order of making shows in one place: when an
        isolated model and a later in-process one both fail to instantiate, the in-process
        one's error is reported (an isolated model's own errors come at setup, in order).
        """
        isolated = self.options.isolate
        return sorted(self.system.components, key=lambda c: c.name in isolated)

    def _make(self, component: Component) -> None:
        """Make and instantiate ``component``'s runner (timed by a profiled run)."""
        runner = self.make_runner(component, self._wiring(component))
        self.runners[component.name] = runner
        if self.profile is not None:
            self.profile.entry(
                component.name, step_phase=getattr(runner, "step_phase", "step")
            )  # the entry's step name, before its work exists
        runner.instantiate()

    def _may_overlap(self, name: str) -> bool:
        """Whether a step of ``name`` is worth a worker thread (a cost choice, see .parallel)."""
        if name in self.options.isolate:
            return True  # a pipe round trip to the model's own process
        return getattr(self.runners[name], "releases_gil", False) is True

    def _plan_parallel(self, entries: list[tuple[Work, int]]) -> None:
        """Decide, before the loop, which steps run on a lane and where the loop joins them."""
        system = self.system
        footprints: dict[int, Footprint] = {}
        lanes: dict[int, Lane] = {}
        lazy: set[int] = set()
        for due, _ in entries:
            members = due.members or (due.name,)
            incoming = [c for m in members for c in system.inputs_of(m)]
            footprints[id(due)] = footprint(members, (c.src.component for c in incoming))
            if any(c.src.port in self.runners[c.src.component].lazy_outputs for c in incoming):
                lazy.add(id(due))
            if due.what == "component" and self._may_overlap(due.name):
                lanes[id(due)] = Lane(due.name, self._marker)
        if not lanes:
            return
        if self.options.frames is not None:
            # Frames go to the sink as they are rendered: a frame rendered while an earlier
            # step is pending could be one the sequential run never renders (if that step
            # faults), so rendering for a sink waits for every pending step first.
            every = frozenset(due.name for due, _ in entries if id(due) in lanes)
            for key in lazy:
                old = footprints[key]
                footprints[key] = Footprint(old.members, old.reads | every)
        issues = plan(self._table, footprints, set(lanes), lanes)
        if any(issue.lane is not None for slot in issues for issue in slot):
            self._issues = issues
            self._lanes = list(lanes.values())

    def _plan_bulk(self) -> BulkLoop | None:
        """The native loop, when one native group is due at every base step and nothing else
        happens between two steps (no other work, lane, watch per step or lazy output)."""
        table = self._table
        if self._hyper != 1 or len(table) != 1 or len(table[0]) != 1 or self._issues:
            return None
        work = table[0][0]
        group = self._groups.get(id(work))
        if group is None or self.profile is not None or self._stamps:
            return None
        tracks = group.tracks
        if {id(t) for t in self.recorder.tracks} != {id(t) for t in tracks}:
            return None
        from fmionnx.runtime.native.bulk import BulkLoop, views_problem

        if views_problem(tracks) is not None:
            return None
        run = self.system.run
        cell = getattr(self._marker, "t_address", None)  # an injected marker may have none
        address = cell() if callable(cell) else 0
        return BulkLoop(
            group.kernel, group, tracks, start=run.start, step=run.step, h=work.h,
            marker_t=address or None,
        )  # fmt: skip

    @property
    def schedule_details(self) -> dict[str, str | int | bool | None]:
        """The run.json fields saying how the steps were scheduled."""
        used = [lane for lane in self._lanes if lane.steps]
        return {
            "native_loop": self._bulk is not None,
            "schedule": self.options.schedule,
            "concurrent": ", ".join(lane.name for lane in used) or None,
            "concurrent_steps": sum(lane.steps for lane in used),
        }

    def _entries(self, dues: dict[str, Work]) -> list[tuple[Work, int]]:
        """(work, period) in execution order; native groups replace their members."""
        plan = plan_native(
            self.system, self.runners, self._tracks, nonfinite=self.options.on_nonfinite
        )
        self.native = plan.status
        entries = []
        for item in plan.schedule:
            if isinstance(item, str):
                loop = self.system.loop_of(item) if self.system.loops else None
                if loop is None:
                    entries.append((dues[item], self.system.component(item).period_steps))
                elif item == loop.members[0]:  # the loop's members are consecutive
                    steps = self.system.component(item).period_steps
                    entries.append((self._loop_due(loop, dues), steps))
            else:
                h = dues[item.names[0]].h
                label = "+".join(item.names)
                work = Work(label, (), item.step, h, None, None, tuple(item.names), "group")
                self._groups[id(work)] = item
                if self.profile is not None:
                    work = self.profile.timed(work)
                entries.append((work, item.period_steps))
        self._watch(entries)
        return entries

    def _loop_due(self, loop: AlgebraicLoop, dues: dict[str, Work]) -> Work:
        """One entry iterating an algebraic loop in place of its members (:mod:`.loops`).

        The members' own transfers and steps are what the loop sweeps; it records their
        tracks itself once it has converged.
        """
        from fmionnx.runtime.loops import iterated_loop

        work = {name: dues[name] for name in loop.members}
        solver = iterated_loop(self.system, loop, self.runners, work, self.nonfinite)
        self.loops.append(solver)
        h = dues[loop.members[0]].h
        return Work(solver.label, (), solver.step, h, None, None, tuple(loop.members), "loop")

    def _watch(self, entries: list[tuple[Work, int]]) -> None:
        """Time the steps of components in this process when a step timeout is set.

        Isolated components time their own steps (their proxy kills a hung child).
        """
        if self._watchdog is None:
            return
        for due, _ in entries:
            if due.name not in self.options.isolate:
                self._watchdog.watch(due)

    def _wiring(self, component: Component) -> Wiring:
        incoming = self.system.inputs_of(component.name)
        sizes: dict[str, int] = {}
        for connection in incoming:
            sizes[connection.dst.port] = sizes.get(connection.dst.port, 0) + connection.size
        return Wiring(frozenset(c.dst.port for c in incoming), sizes)

    def _producer_hook(self, src: PortRef) -> Callable[[], None] | None:
        """For a lazy output: a closure producing it at most once per producer step."""
        runner = self.runners[src.component]
        port = src.port
        if port not in runner.lazy_outputs:
            return None
        key = f"{src.component}.{port}"
        stamps = self._stamps
        stamps.setdefault(key, -1)
        owner = src.component
        sink = self.options.frames
        buffer = runner.output_buffer(port)
        shape = tuple(int(d) for d in runner.component.port(port).shape if isinstance(d, int))
        start, step = self.system.run.start, self.system.run.step
        clock = self._clock
        refresh: Callable[[], None] = lambda: runner.produce(port)  # noqa: E731
        profile = self.profile
        if profile is not None:
            refresh = profile.render(owner, refresh)

        def produce() -> None:
            version = stamps[owner]
            if stamps[key] != version:
                refresh()
                stamps[key] = version
                if sink is not None:
                    time = start + clock[0] * step
                    image = buffer.reshape(shape)
                    if profile is None:
                        sink.frame(owner, port, time, image)
                    else:
                        profile.viewed(lambda: sink.frame(owner, port, time, image))

        return produce

    def _due(self, component: Component) -> Work:
        system = self.system
        runner = self.runners[component.name]
        transfers = [
            make_transfer(
                connection,
                self.runners[connection.src.component],
                runner,
                self._producer_hook(connection.src),
                self.nonfinite,
            )
            for connection in system.inputs_of(component.name)
        ]
        step_fn = runner.step
        if component.name in self._stamps:
            stamps = self._stamps
            name = component.name
            inner = step_fn

            def step_and_stamp(t: float, h: float) -> None:
                inner(t, h)
                stamps[name] += 1

            step_fn = step_and_stamp
        before, after = self._tracks.get(component.name, (None, None))
        h = component.period_steps * system.run.step
        work = Work(component.name, tuple(transfers), step_fn, h, before, after, (component.name,))
        if self.profile is None:
            return work
        return self.profile.timed(work, getattr(runner, "step_phase", "step"))

    # -- recording -----------------------------------------------------------------------------

    @property
    def record_refs(self) -> tuple[PortRef, ...]:
        """The signals this run records (options, else the system's list, else the default)."""
        if self.options.record is not None:
            return self.options.record
        chosen = self.system.record or default_record(self.system)
        return (*chosen, *required_refs(self.system))

    def _build_tracks(self) -> None:
        """One track for recorded inputs (sampled before a step), one for outputs (after)."""
        system = self.system
        total = system.run.steps
        seen: set[str] = set()
        sides: dict[str, tuple[list[tuple[list[str], Buffer]], list[tuple[list[str], Buffer]]]]
        sides = {}
        for ref in self.record_refs:
            port = system.component(ref.component).port(ref.port)
            runner = self.runners[ref.component]
            if is_image(port) or port.name in runner.lazy_outputs:
                continue
            names = column_names(ref.component, port, ref.index)
            if any(n in seen for n in names):
                continue
            is_output = port.causality is Causality.OUTPUT
            try:
                buffer = (
                    runner.output_buffer(port.name) if is_output else runner.input_buffer(port.name)
                )
            except KeyError:
                continue  # e.g. a string variable: not a run-time signal
            seen.update(names)
            self.recorder.order.extend(names)
            if ref.index is not None:
                i = flat_index(port, ref.index)
                buffer = buffer[i : i + 1]
            side = sides.setdefault(ref.component, ([], []))
            side[1 if is_output else 0].append((names, buffer))
        for name, (inputs, outputs) in sides.items():
            period = system.component(name).period_steps
            tracks: list[Track | None] = []
            for items in (inputs, outputs):
                track = self.recorder.track(period, total) if items else None
                for names, buffer in items:
                    assert track is not None
                    track.add(names, buffer)
                if track is not None:
                    track.allocate()
                tracks.append(track)
            before, after = tracks
            if after is not None:
                after.sample()  # outputs after initialization: the row at the start time
            self._tracks[name] = (before, after)

    # -- the loop ------------------------------------------------------------------------------

    def run(self) -> RunResult:
        """Prepare, loop to the stop time (or a fault / Ctrl-C), terminate, collect results."""
        started = _time.perf_counter()
        with self._stop_notice():
            return self._run(started)

    def _stop_notice(self) -> contextlib.AbstractContextManager[object]:
        """Stop signals noticed by the watchdog while a model in this process keeps the main
        thread (:mod:`.stopnotice`); not in a guarded child, whose guardian stops it."""
        watchdog = self._watchdog
        instruments = self.options.instruments or PLAIN
        if watchdog is None or not instruments.notices_stops:
            return contextlib.nullcontext()
        from fmionnx.runtime.stopnotice import StopNotice

        notice = watchdog.notice = StopNotice()
        return notice

    def _run(self, started: float) -> RunResult:
        system = self.system
        status = RunStatus.COMPLETED
        error: RunError | None = None
        reason: str | None = None
        try:
            if self._watchdog is not None:  # loading and initializing are timed too
                self._watchdog.start()
            self.prepare()
            if self.options.rtf > 0 and self.profile is not None:
                from fmionnx.runtime.pacing import Pacer

                self._pacer = Pacer(
                    self.options.rtf, system.run.start, system.run.step, self.profile
                )
            started = self._started = _time.perf_counter()
            if self._pacer is not None:
                self._pacer.begin()
            self._loop()
        except RunError as exc:
            status, error = RunStatus.FAULT, exc
        except KeyboardInterrupt as exc:
            status, reason = RunStatus.INTERRUPTED, stop_reason(exc)
        finally:
            wall = _time.perf_counter() - started
            with stops_held() as late:  # the models end in order, whatever comes now
                self._end_here()
                try:
                    self._terminate(skip=self._close_lanes())
                finally:
                    if self._watchdog is not None:  # after terminating, which is timed too
                        self._watchdog.stop()
        n = self._clock[0]
        result = RunResult.after(
            system, BACKEND_NAME, status, n, wall, self.recorder.table(n), error,
            self.details(), reason, self.ended_by,
        )  # fmt: skip
        if late:
            result.warnings.append(late_stop_text(late[0]))
        self._watched(result, wall)
        return result

    def _watched(self, result: RunResult, wall: float) -> None:
        """What the watching options add to ``result``: statistics, pacing, warnings."""
        if self.nonfinite is not None:
            result.warnings.extend(self.nonfinite.messages())
        if self.profile is not None and self.options.profile:
            concurrent = any(lane.steps for lane in self._lanes)
            result.statistics = self.profile.report(
                wall, concurrent=concurrent, schedule=self.options.schedule
            )
        pacer = self._pacer
        if pacer is not None:
            result.pacing = pacer.report()
            warning = pacer.warning()
            if warning is not None:
                result.warnings.append(warning)

    def details(self) -> dict[str, str | int | bool | None]:
        """run.json's ``execution``: the native kernel's use and the schedule."""
        return {**self.native.details(), **self.schedule_details}

    def _ticker(self) -> tuple[ProgressCallback | None, int]:
        """The loop's progress call and how many base steps apart: the observers' (every
        ``progress_every``), or, in a paced run, the pacer's after every base step, passing
        the observers' on at their own interval."""
        progress = self.options.progress
        every = max(1, self.options.progress_every)
        pacer = self._pacer
        if pacer is None:
            return progress, every

        def paced(done: int, total: int, time: float) -> None:
            pacer(done)
            if progress is not None and ((done - 1) % every == 0 or done == total):
                progress(done, total, time)

        return paced, 1

    def _loop(self) -> None:
        if self._issues:
            self._loop_parallel()
            return
        if self._bulk is not None:
            self._loop_bulk(self._bulk)
            return
        run = self.system.run
        start, step, total = run.start, run.step, run.steps
        clock = self._clock
        progress, every = self._ticker()
        table, hyper = self._table, self._hyper
        marker = self._marker
        checkpoint = self.options.checkpoint
        next_checkpoint = _time.perf_counter() + self.options.checkpoint_every
        for n in range(total):
            clock[0] = n
            t = start + n * step
            if (
                checkpoint is not None
                and n % every == 0
                and _time.perf_counter() >= next_checkpoint
            ):
                next_checkpoint = self._checkpoint(n)
            marker.t = t
            try:
                for due in table[n % hyper] if hyper else self._due_at(n):
                    due.perform(t)  # the stepping core: feed, record, mark, step, record
            except ModelTerminated as exc:  # the step completed: its outputs are the last row
                self._end_by(exc, n)
                return
            if progress is not None and n % every == 0:
                progress(n + 1, total, start + (n + 1) * step)
        clock[0] = total
        if progress is not None:
            progress(total, total, run.stop)

    def _loop_bulk(self, bulk: BulkLoop) -> None:
        """The sequential loop's steps, many per call into the native kernel (:mod:`.native.bulk`).

        Between two calls it does what :meth:`_loop` does between two steps: a checkpoint when
        one is due, the progress call after each ``every``-th step, a stop request.
        """
        run = self.system.run
        start, step, total = run.start, run.step, run.steps
        clock = self._clock
        progress, every = self._ticker()
        marker = self._marker
        marker.work = self._table[0][0]
        h = self._table[0][0].h
        checkpoint = self.options.checkpoint
        next_checkpoint = _time.perf_counter() + self.options.checkpoint_every
        n = 0
        while n < total:
            if checkpoint is not None and _time.perf_counter() >= next_checkpoint:
                next_checkpoint = self._checkpoint(n)
            last = total if progress is None else min(total, -(-n // every) * every + 1)
            shield_begin()  # a stop request waits until the counts and the clock agree
            self._in_bulk = True
            try:
                code, n = bulk.run(n, last)
                clock[0] = n
                marker.t = start + (n if code else n - 1) * step
            finally:
                self._in_bulk = False
                shield_end()
            if code:
                try:
                    raise bulk.group.fault(code, start + n * step, h)
                except ModelTerminated as exc:  # the step completed: its outputs are the last row
                    self._end_by(exc, n)
                    return
            if progress is not None and (n - 1) % every == 0:
                progress(n, total, start + n * step)
        clock[0] = total
        if progress is not None:
            progress(total, total, run.stop)

    # -- the parallel loop (see :mod:`.parallel` and docs/execution.md, "Parallel schedule") --

    def _loop_parallel(self) -> None:
        """The sequential loop's work in the same order, some steps handed to lanes.

        A failure (a fault, a model ending the run) is settled as the sequential run would
        have met it: the earliest one in the sequential order wins, and what was done after
        it is taken back from the recording (:meth:`_settle`).
        """
        run = self.system.run
        start, step, total = run.start, run.step, run.steps
        clock = self._clock
        progress, every = self._ticker()
        paced = self._pacer is not None
        issues, hyper = self._issues, self._hyper
        index = self._entry_index
        marker = self._marker
        checkpoint = self.options.checkpoint
        next_checkpoint = _time.perf_counter() + self.options.checkpoint_every
        n = 0
        due: Work | None = None
        try:
            for n in range(total):
                clock[0] = n
                t = start + n * step
                if (
                    checkpoint is not None
                    and n % every == 0
                    and _time.perf_counter() >= next_checkpoint
                ):
                    self._drain()
                    next_checkpoint = self._checkpoint(n)
                marker.t = t
                for issue in issues[n % hyper]:
                    due = None
                    for lane in issue.joins:
                        if lane.job is not None:
                            self._join(lane)
                    work = issue.work
                    assert isinstance(work, Work)
                    due = work
                    due.feed(t)
                    due.record_inputs()
                    worker = issue.lane
                    if worker is None:  # a failure here is settled as the sequential run's
                        marker.work = due
                        due.advance(t)
                        due.record_outputs()
                    else:
                        worker.submit(Job(due, due.step, t, due.h, n, index[id(due)]))
                due = None
                if progress is not None and n % every == 0:
                    if paced:  # the base step ends with its lanes' work: the pacer's
                        self._drain()  # breakdown of a late step missed what they took
                    progress(n + 1, total, start + (n + 1) * step)
            self._drain()
        except _StepFailedError as failed:
            self._settle(failed.job, failed.error)
            return
        except KeyboardInterrupt:
            self._drain_quietly()
            raise
        except BaseException as exc:
            if due is None:  # not from a step or a transfer: the loop itself
                self._drain_quietly()
                raise
            self._settle(Job(due, due.step, start + n * step, due.h, n, index[id(due)]), exc)
            return
        clock[0] = total
        if progress is not None:
            progress(total, total, run.stop)

    def _join(self, lane: Lane) -> None:
        """Wait for ``lane``'s pending step and record its outputs (raises :class:`_StepFailedError`)."""
        job, outcome = self._await(lane)
        if outcome is not None:
            raise _StepFailedError(job, outcome)

    def _await(self, lane: Lane, *, record: bool = True) -> tuple[Job, BaseException | None]:
        """Wait for ``lane``'s pending step; record its outputs if it completed (``record``).

        Returns the step and what it raised (None: it completed). While waiting, the
        watchdog's marker names that step, so a concurrent step that hangs is reported as
        itself, wherever the loop waits for it (a join, a drain, a settlement, the end).
        """
        marker = self._marker
        job = lane.job
        assert job is not None
        self._joining = job
        work, t = marker.work, marker.t
        marker.work, marker.t = job.work, job.t
        try:
            lane.wait_finished()
        finally:
            marker.work, marker.t = work, t
            self._joining = None
        shield_begin()  # a stop signal here would lose the finished step's outcome or outputs
        try:
            job, outcome = lane.take()
            if record and outcome is None:
                after = job.work.after  # type: ignore[attr-defined]
                if after is not None:
                    after.sample()
        finally:
            shield_end()
        return job, outcome

    def _drain(self) -> None:
        """Join every pending step (before a checkpoint and at the end of the run)."""
        for lane in self._lanes:
            if lane.job is not None:
                self._join(lane)

    def _drain_quietly(self) -> None:
        """Wait for every pending step, recording those that completed (Ctrl-C, a bug)."""
        for lane in self._lanes:
            if lane.job is not None:
                self._await(lane)

    def _settle(self, job: Job, error: BaseException) -> None:
        """End the run at the earliest failure in the sequential order, as that run would.

        ``job`` is the failed step (its work, time and place). Every other pending step is
        waited for; a failure earlier in the sequential order replaces this one. The
        recording then keeps exactly the steps the sequential run completed before it.
        """
        failures = [(job.n, job.index, job, error)]
        for lane in self._lanes:
            if lane.job is not None:
                other, outcome = self._await(lane)
                if outcome is not None:
                    failures.append((other.n, other.index, other, outcome))
        n, place, job, error = min(failures, key=lambda failure: (failure[0], failure[1]))
        work = job.work
        assert isinstance(work, Work)
        after = work.after
        completed = isinstance(error, ModelTerminated)
        if completed and after is not None and after.count <= self._allowed(work, n, place) + 1:
            after.sample()  # the step completed: its outputs are the last row
        self._truncate(n, place, work)
        self._clock[0] = n
        if isinstance(error, ModelTerminated):
            self._end_by(error, n)
            return
        raise error

    def _allowed(self, work: Work, n: int, place: int) -> int:
        """How many steps of ``work`` the sequential order issues before place ``place`` at n."""
        period = next(p for due, p in self._entry_list if due is work)
        before = -(-n // period)
        if n % period == 0 and self._entry_index[id(work)] < place:
            before += 1
        return before

    def _truncate(self, n: int, place: int, failed: Work) -> None:
        """Take back every recorded row of work issued after (n, place) in the order."""
        for due, _ in self._entry_list:
            if due is failed:
                continue
            issued = self._allowed(due, n, place)
            for name in due.members or (due.name,):
                before, after = self._tracks.get(name, (None, None))
                if before is not None:
                    before.truncate(issued)
                if after is not None:
                    after.truncate(issued + 1)

    def _close_lanes(self) -> set[str]:
        """No step may still run when the runners are freed; then let the workers end.

        Returns the components whose step is still running (a repeated stop signal ended the
        wait): their runners must not be freed under the step (see :meth:`_terminate`).
        """
        busy: set[str] = set()
        for lane in self._lanes:
            if lane.job is not None:
                with contextlib.suppress(BaseException):  # the run's outcome is decided
                    self._await(lane, record=False)
                if lane.job is not None:
                    busy.add(lane.name)
            lane.close()
        return busy

    def _end_by(self, request: ModelTerminated, n: int) -> None:
        """A model asked to end the run during its step from ``t_n``: end it normally there.

        The run ends at the end of that step (``t_n + period``, at most the stop time), so the
        last row holds the step's outputs; components after it in the order do not step at
        ``t_n`` and, like every component between its steps, hold their values to that row.
        """
        run = self.system.run
        name = request.component or ""
        period = self.system.component(name).period_steps if name else 1
        end = min(n + period, run.steps)
        self._clock[0] = end
        self.ended_by = EndedBy(name, run.start + end * run.step, request.reason)

    def _partial(
        self, status: RunStatus, error: RunError | None = None, reason: str | None = None
    ) -> RunResult:
        """The results of the steps completed so far (``reason``: the stop signal's name)."""
        n = self._clock[0]
        wall = _time.perf_counter() - self._started
        return RunResult.after(
            self.system, BACKEND_NAME, status, n, wall, self.recorder.table(n), error,
            self.details(), reason,
        )  # fmt: skip

    def _checkpoint(self, n: int) -> float:
        """Hand the results so far to the checkpoint callback; returns when to do it again.

        The interval grows with the cost of a checkpoint (at least 10x what it took), so
        checkpoints never cost more than a tenth of a long run.
        """
        callback = self.options.checkpoint
        assert callback is not None
        began = _time.perf_counter()
        callback(self._partial(RunStatus.RUNNING))
        took = _time.perf_counter() - began
        return _time.perf_counter() + max(self.options.checkpoint_every, 10 * took)

    def _end_here(self) -> None:
        """The loop's thread ends the run from here, unless the watchdog abandons it already:
        then it waits for the process to end (the abandoning thread writes the results and
        exits; terminating the models here too would end them twice)."""
        with self._ending:
            abandoning = self._ends == "abandon"
            if not abandoning:
                self._ends = "loop"
        if abandoning:
            threading.Event().wait()

    def _abandon(self, work: object, t: float, stop: int | None = None) -> bool:
        """A step in this process overran the step timeout, or kept a stop signal (``stop``)
        waiting: write what we have, then exit (status 1, or 128 + the signal's number).

        Called on the watchdog's thread while the main thread is stuck in the model; ``work``
        is the scheduled work (a :class:`Work`) the loop marked before the step, or the
        :class:`~.watchdog.Phase` (loading, initializing, terminating) of one component.
        Returns False, abandoning nothing, for a stop the loop's thread came back for in the
        meantime (it ends the run itself: see :meth:`_end_here`).
        """
        assert isinstance(work, Work | Phase)
        with self._ending:
            came_back = self._marker.work is not work or self._marker.t != t
            if self._ends == "loop" and (stop is not None or came_back):
                return False  # the loop's thread ends the run (a hung termination excepted)
            self._ends = "abandon"
        try:  # from here on the process ends, whatever fails on the way
            self._write_abandoned(work, t, stop)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(1 if stop is None else exit_code(signal.Signals(stop).name))

    def _write_abandoned(self, work: Work | Phase, t: float, stop: int | None) -> None:
        """The abandoned run's results, handed over or said, and the other models ended."""
        label = work.name
        timeout = self.options.step_timeout
        assert timeout is not None
        if self._in_bulk and self._bulk is not None:  # the marker moves on between chunks only
            n = self._clock[0] = self._bulk.under_way()
            t = self.system.run.start + n * self.system.run.step
        error = fault(
            label,
            f"{overrun_text(work, timeout)}; the component runs in fmionnx's own process, so "
            "the run was abandoned (`--isolate` runs a model in a process of its own, which "
            "can be stopped)",
            time=t,
        )
        busy = self._abandon_concurrent(work) if self._issues and isinstance(work, Work) else set()
        if stop is None:
            result = self._partial(RunStatus.FAULT, error)
        else:
            result = self._stuck_at_stop(work, stop)
        if self.options.abandon is not None:
            self.options.abandon(result)
        elif stop is None:
            print(f"fault: {error}", file=sys.stderr)
        else:
            print(f"interrupted by {result.interrupted_by}: {result.warnings[-1]}")
        for runner in list(self.runners.values()):
            name = runner.component.name
            if name not in label.split("+") and name not in busy:
                with contextlib.suppress(Exception):
                    runner.terminate()

    def _stuck_at_stop(self, work: Work | Phase, stop: int) -> RunResult:
        """The results so far of a run stopped by signal ``stop`` while ``work`` kept the
        main thread, and a warning that says so."""
        name = signal.Signals(stop).name
        result = self._partial(RunStatus.INTERRUPTED, reason=name)
        what = work.what if isinstance(work, Phase) else "its step"
        result.warnings.append(
            f"component `{work.name}` did not return from {what} after {name}: it runs in "
            "fmionnx's own process, so the run was abandoned, its results so far kept "
            "(`--isolate` runs a model in a process of its own, which can be stopped)"
        )
        return result

    def _abandon_concurrent(self, work: object) -> set[str]:
        """Before an abandoned run's results are written: record the concurrent steps that
        completed, and take back what was issued after the hung step.

        Returns the components whose step may still be running (not to be terminated).
        """
        hung = self._joining
        if hung is not None and hung.work is work:
            n, place = hung.n, hung.index
        else:
            assert isinstance(work, Work)
            n, place = self._clock[0], self._entry_index.get(id(work), 0)
        busy: set[str] = set()
        for lane in self._lanes:
            job = lane.job
            if job is None or job is hung:
                continue
            if lane.done():
                job, outcome = lane.wait()
                after = job.work.after  # type: ignore[attr-defined]
                if outcome is None and after is not None:
                    after.sample()
            else:
                busy.add(lane.name)
        assert isinstance(work, Work)
        self._truncate(n, place, work)
        self._clock[0] = n
        return busy

    def _due_at(self, n: int) -> tuple[Work, ...]:
        return tuple(due for due, p in self._fallback if n % p == 0)

    def _terminate(self, skip: set[str] | frozenset[str] = frozenset()) -> None:
        """Free every runner but those in ``skip`` (a step of theirs may still be running)."""
        profile = self.profile
        for name, runner in self.runners.items():
            if name in skip:
                continue
            with contextlib.suppress(Exception):  # freeing after a fault must not mask it
                if profile is None:
                    runner.terminate()
                else:
                    profile.timed_once(name, "terminate", runner.terminate)
