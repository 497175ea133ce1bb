"""Per-component statistics (``--profile``): where a run's wall time went, phase by phase.

When a run is profiled, the master (and a ROS 2 node) builds its works as :class:`TimedWork`,
the stepping core's :class:`~fmionnx.runtime.stepping.Work` with a stopwatch around each
phase, instead of the plain one; nothing else in the loop changes, and a run that is not
profiled runs the plain works, at the plain cost. Each unit of work has an :class:`Entry`:

* ``instantiate`` (making the runner and loading the model), ``initialize`` (``setup``:
  parameters, initialization mode) and ``terminate``, timed once;
* ``transfer`` — feeding its inputs (the connections' copies), *less* any frame rendered on
  demand meanwhile, which is the producer's ``render``;
* ``step`` — its step (a runner that says ``step_phase = "infer"``, the ONNX kind's, reports
  it as ``infer``): the step count, their total, mean and largest;
* ``render`` — producing a lazy output (a camera frame) when a consumer first reads it;
* ``record`` — sampling its recorded inputs and outputs.

A native group (:mod:`fmionnx.runtime.native`) does all of that for its members in one C call:
it is one entry (``a+b+c``, with its members), timed as a step. An isolated component's step
includes the round trip to its process. In the parallel schedule a step handed to a worker
thread overlaps the loop's other work, so the components' times can add up to more than the
loop's wall time (``concurrent`` says so). Time outside every component — the views' frame
hooks, a paced run's waits, the loop itself — is reported beside them (``other``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields

from fmionnx.core.errors import ModelTerminated
from fmionnx.runtime.result import Detail
from fmionnx.runtime.stepping import StepFunction, Work

#: The phases a component's time is split into, in the order a table shows them.
PHASES = ("instantiate", "initialize", "transfer", "render", "step", "record", "terminate")
#: The phases spent inside the loop (what the share of the loop counts).
LOOP_PHASES = ("transfer", "render", "step", "record")

_clock = time.perf_counter


@dataclass(slots=True)
class Entry:
    """The time one unit of work (a component, a native group) spent in each phase."""

    name: str
    members: tuple[str, ...] = ()
    #: ``component``, ``group`` (native kernel) or ``loop`` (iterated algebraic loop).
    what: str = "component"
    #: What its step is called in the table (``infer`` for an ONNX model).
    step_phase: str = "step"
    steps: int = 0
    step_max: float = 0.0
    times: dict[str, float] = field(default_factory=lambda: dict.fromkeys(PHASES, 0.0))

    @property
    def busy(self) -> float:
        """Seconds spent in the loop's phases."""
        times = self.times
        return times["transfer"] + times["render"] + times["step"] + times["record"]

    def as_json(self, loop_wall: float) -> dict[str, Detail]:
        """run.json's entry: steps, phases (the step under its own name), mean, max, share."""
        times = self.times
        phases: dict[str, Detail] = {
            (self.step_phase if p == "step" else p): round(times[p], 6) for p in PHASES
        }
        busy = self.busy
        found: dict[str, Detail] = {
            "what": self.what,
            "steps": self.steps,
            "phases": phases,
            "step_mean": round(times["step"] / self.steps, 9) if self.steps else None,
            "step_max": round(self.step_max, 9) if self.steps else None,
            "loop_time": round(busy, 6),
            "share": round(busy / loop_wall, 4) if loop_wall > 0 else None,
        }
        if self.what != "component":
            found["members"] = ", ".join(self.members)
        return found


class Profile:
    """The entries of one run (or one ROS 2 node) and the time spent outside them."""

    def __init__(self) -> None:
        self.entries: dict[str, Entry] = {}
        #: Seconds of lazy outputs rendered so far (subtracted from the consumer's transfer).
        self.rendered = 0.0
        #: Seconds in the views' frame hooks (subtracted likewise; reported under ``other``).
        self.viewing = 0.0
        #: Seconds a paced run waited for the wall clock (:mod:`fmionnx.runtime.pacing`).
        self.waited = 0.0

    def entry(
        self,
        name: str,
        members: Sequence[str] = (),
        what: str = "component",
        step_phase: str = "step",
    ) -> Entry:
        """The entry of ``name`` (made on first use)."""
        found = self.entries.get(name)
        if found is None:
            found = Entry(name, tuple(members) or (name,), what, step_phase)
            self.entries[name] = found
        return found

    def timed_once(self, name: str, phase: str, call: Callable[[], object]) -> None:
        """Run ``call`` and add its time to ``name``'s ``phase`` (instantiate, initialize,
        terminate), also when it raises."""
        began = _clock()
        try:
            call()
        finally:
            self.entry(name).times[phase] += _clock() - began

    def render(self, owner: str, produce: Callable[[], None]) -> Callable[[], None]:
        """``produce`` (a lazy output's refresh) timed as ``owner``'s ``render``."""
        times = self.entry(owner).times

        def timed_render() -> None:
            began = _clock()
            produce()
            took = _clock() - began
            times["render"] += took
            self.rendered += took

        return timed_render

    def viewed(self, hook: Callable[[], None]) -> None:
        """Run a view's frame hook, its time set apart from every component's."""
        began = _clock()
        hook()
        self.viewing += _clock() - began

    def timed(self, work: Work, step_phase: str = "step") -> TimedWork:
        """``work`` with a stopwatch on each phase (module docstring)."""
        entry = self.entry(work.name, work.members, work.what, step_phase)
        values = {f.name: getattr(work, f.name) for f in fields(work)}
        values["step"] = _timed_step(entry, work.step)
        return TimedWork(**values, entry=entry, profile=self)

    def totals(self) -> list[float]:
        """Each entry's loop time so far, in entry order (a paced run's snapshot)."""
        return [entry.busy for entry in self.entries.values()]

    def report(
        self, loop_wall: float, *, concurrent: bool = False, schedule: str | None = None
    ) -> dict[str, Detail]:
        """run.json's ``statistics``: the components by share of the loop, and the rest."""
        ordered = sorted(self.entries.values(), key=lambda e: e.busy, reverse=True)
        attributed = sum(e.busy for e in ordered)
        other: dict[str, Detail] = {
            "views": round(self.viewing, 6),
            "paced_wait": round(self.waited, 6),
            "loop": round(max(0.0, loop_wall - attributed - self.viewing - self.waited), 6)
            if not concurrent
            else None,
        }
        return {
            "loop_wall_time": round(loop_wall, 6),
            "schedule": schedule,
            "concurrent": concurrent,
            "components": {e.name: e.as_json(loop_wall) for e in ordered},
            "other": other,
        }


def _timed_step(entry: Entry, step: StepFunction) -> StepFunction:
    """``step`` counting itself, its total and its largest duration into ``entry``.

    Wrapping the step function, not only :meth:`TimedWork.perform`, times it wherever it
    runs: on the loop's thread, on a worker thread of the parallel schedule, in a loop
    solver's sweeps.
    """
    times = entry.times

    def timed_step(t: float, h: float) -> None:
        began = _clock()
        try:
            step(t, h)
        finally:
            took = _clock() - began
            entry.steps += 1
            times["step"] += took
            entry.step_max = max(entry.step_max, took)

    return timed_step


@dataclass(slots=True)
class TimedWork(Work):
    """A :class:`~fmionnx.runtime.stepping.Work` timing its feed, recording and step."""

    entry: Entry | None = None
    profile: Profile | None = None

    def feed(self, t: float) -> None:
        """The transfers, timed as ``transfer`` less what was rendered meanwhile."""
        profile, entry = self.profile, self.entry
        assert profile is not None
        assert entry is not None
        elsewhere = profile.rendered + profile.viewing
        began = _clock()
        for transfer in self.transfers:
            transfer(t)
        took = _clock() - began
        entry.times["transfer"] += took - (profile.rendered + profile.viewing - elsewhere)

    def record_inputs(self) -> None:
        """Recorded inputs, timed as ``record``."""
        if self.before is not None:
            assert self.entry is not None
            began = _clock()
            self.before.sample()
            self.entry.times["record"] += _clock() - began

    def record_outputs(self) -> None:
        """Recorded outputs, timed as ``record``."""
        if self.after is not None:
            assert self.entry is not None
            began = _clock()
            self.after.sample()
            self.entry.times["record"] += _clock() - began

    def perform(self, t: float) -> None:
        """The phases of :meth:`Work.perform`, each timed."""
        self.feed(t)
        self.record_inputs()
        if self.marker is not None:
            self.marker.work = self
        try:
            self.step(t, self.h)
        except ModelTerminated:
            self.record_outputs()
            raise
        self.record_outputs()
