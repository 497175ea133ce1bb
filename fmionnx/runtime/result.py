"""What a run takes (:class:`RunOptions`) and what it gives back (:class:`RunResult`).

A run never raises for a fault inside the simulation: it returns a :class:`RunResult` whose
``status`` says how it ended and whose ``error`` names component, port and simulated time, so
that callers can still write the results recorded up to that point.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.errors import RunError
from fmionnx.core.types import PortRef

if TYPE_CHECKING:
    from pathlib import Path

    from fmionnx.runtime.instruments import Instruments
    from fmionnx.runtime.published import Follower
    from fmionnx.runtime.recorder import FrameSink
    from fmionnx.runtime.transfer import NonFinitePolicy

#: A value of ``RunResult.details`` (JSON: scalars, or objects of them such as per-node counts).
Detail = str | int | float | bool | None | dict[str, "Detail"]


class RunStatus(enum.StrEnum):
    """How a run ended; ``run.json`` records it and the CLI maps it to an exit code."""

    COMPLETED = "completed"
    FAULT = "fault"
    INTERRUPTED = "interrupted"
    #: A checkpoint written while the run goes on: found on disk, it means the process ended
    #: without writing its final results (SIGKILL, power loss).
    RUNNING = "running"


@dataclass(frozen=True)
class EndedBy:
    """A run a model ended before its stop time (FMI ``terminateSimulation``): not a fault.

    ``time`` is the simulated time the run ended at (the time of the last row).
    """

    component: str
    time: float
    reason: str

    def as_dict(self) -> dict[str, str | float]:
        """The ``ended_by`` object of ``run.json``."""
        return {"component": self.component, "time": self.time, "reason": self.reason}


#: How the in-process master schedules steps (``--schedule``).
Schedule = Literal["parallel", "sequential"]

#: ``progress(steps_done, total_steps, time)``; called every few hundred steps.
ProgressCallback = Callable[[int, int, float], None]

#: Receives a partial result: a checkpoint (status ``running``) or an abandoned run (``fault``).
ResultCallback = Callable[["RunResult"], None]


@dataclass(frozen=True)
class RunOptions:
    """What the caller chooses per run (the system itself is immutable).

    ``record``: signals written to the results (None: the system's ``record`` list, else every
    connected non-image output; an empty tuple records nothing, as a benchmark wants).
    ``frames``: a sink for camera frames and signals (MCAP recording); None records no frames.
    """

    record: tuple[PortRef, ...] | None = None
    progress: ProgressCallback | None = None
    progress_every: int = 500
    frames: FrameSink | None = None
    #: Components whose models run in a child process of their own (``--isolate``).
    isolate: frozenset[str] = frozenset()
    #: Seconds one step of a component may take before the run stops with a fault (None: no
    #: limit). Isolated components are killed; see :mod:`fmionnx.runtime.watchdog` otherwise.
    step_timeout: float | None = None
    #: Confine isolated components (``--sandbox``: no network, no files outside their own).
    sandbox: bool = False
    #: Receives the results so far every ``checkpoint_every`` seconds of wall time (at least),
    #: so that a run killed outright (SIGKILL) loses only its last seconds.
    checkpoint: ResultCallback | None = None
    checkpoint_every: float = 10.0
    #: Receives the results of a run abandoned because an in-process step overran the step
    #: timeout, just before the process ends (exit status 1); see :mod:`.watchdog`.
    abandon: ResultCallback | None = None
    #: ``parallel`` (default): steps that may overlap others run on worker threads, with
    #: results bit-identical to ``sequential``, where every step runs on the loop's thread
    #: (docs/execution.md, "Parallel schedule").
    schedule: Schedule = "parallel"
    #: The run's results folder, for backends that leave files of their own there (ROS 2:
    #: the compiled system, logs and node rows); None: no folder (they use a scratch one).
    out: Path | None = None
    #: ``--record FILE`` for a backend that records by itself (ROS 2: every topic as it
    #: crossed the wire); in-process recordings arrive through ``frames``.
    record_file: Path | None = None
    #: Puts the rows a guarded run publishes to use while it goes (results.csv formatted
    #: ahead, :mod:`fmionnx.results.csvahead`); None: nobody follows.
    follower: Follower | None = None
    #: The in-process master's recorder, marker and runner wrapper (None: its own; see
    #: :mod:`fmionnx.runtime.instruments`).
    instruments: Instruments | None = None
    #: What a NaN or infinity leaving a producer on a connection does: ``fault`` (the run
    #: stops, naming component, port and time) or ``warn`` (noted once per connection, passed
    #: on); see :mod:`fmionnx.runtime.transfer`.
    on_nonfinite: NonFinitePolicy = "fault"
    #: Time every component's phases (``--profile``): the result's ``statistics``
    #: (:mod:`fmionnx.runtime.profile`). Off, the loop is the plain one.
    profile: bool = False
    #: Pace the run to this many times real time (``--rtf``; 0: as fast as it goes). The
    #: result's ``pacing`` says how well it kept up (:mod:`fmionnx.runtime.pacing`).
    rtf: float = 0.0


@dataclass
class RunResult:
    """What a run produced: recorded signals at every base step up to where it stopped."""

    system: str
    backend: str
    status: RunStatus
    start: float
    stop: float
    step: float
    steps_done: int
    wall_time: float
    time: npt.NDArray[np.float64]
    signals: dict[str, npt.NDArray[np.float64]] = field(default_factory=dict)
    error: RunError | None = None
    #: Backend-specific facts about how the run executed (e.g. the in-process ``native``
    #: kernel), written to run.json as ``execution``.
    details: dict[str, Detail] = field(default_factory=dict)
    #: For an interrupted run: the signal that stopped it (``SIGINT``, ``SIGTERM``, ``SIGHUP``).
    interrupted_by: str | None = None
    #: For a completed run that a model ended before the stop time: which, when and why.
    ended_by: EndedBy | None = None
    #: What the run noticed and went on with (a non-finite value passed on, a paced run that
    #: fell behind): shown after the run and written to run.json's ``warnings``.
    warnings: list[str] = field(default_factory=list)
    #: Per component: steps and wall time per phase (``--profile``; run.json's ``statistics``,
    #: :mod:`fmionnx.runtime.profile`); None when not asked for.
    statistics: dict[str, Detail] | None = None
    #: How a paced run (``--rtf``) kept up (run.json's ``pacing``); None when unpaced.
    pacing: dict[str, Detail] | None = None

    @classmethod
    def after(
        cls,
        system: CompiledSystem,
        backend: str,
        status: RunStatus,
        steps_done: int,
        wall_time: float,
        signals: dict[str, npt.NDArray[np.float64]],
        error: RunError | None = None,
        details: Mapping[str, Detail] | None = None,
        interrupted_by: str | None = None,
        ended_by: EndedBy | None = None,
    ) -> RunResult:
        """The result of ``system`` after ``steps_done`` base steps: run settings and the time
        column (``t_0 .. t_n``, computed, never accumulated) come from the system.

        ``signals`` holds every base step; with an output interval only every k-th row and the
        last one are kept (:func:`output_rows`), for every backend alike.
        """
        run = system.run
        every = run.output_every
        if every > 1:
            rows = output_rows(steps_done, every)
            signals = {name: values[rows] for name, values in signals.items()}
            time = np.asarray(run.start + rows * run.step, dtype=np.float64)
        else:
            time = np.asarray(run.start + np.arange(steps_done + 1) * run.step, dtype=np.float64)
        return cls(
            system=system.name,
            backend=backend,
            status=status,
            start=run.start,
            stop=run.stop,
            step=run.step,
            steps_done=steps_done,
            wall_time=wall_time,
            time=time,
            signals=signals,
            error=error,
            details=dict(details or {}),
            interrupted_by=interrupted_by,
            ended_by=ended_by,
        )

    @property
    def simulated_time(self) -> float:
        """Seconds of simulated time actually covered."""
        return self.steps_done * self.step

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second (> 1 is faster than real time)."""
        if self.wall_time <= 0:
            return float("inf")
        return self.simulated_time / self.wall_time

    def __getitem__(self, name: str) -> npt.NDArray[np.float64]:
        """A recorded signal by column name (``time`` too)."""
        if name == "time":
            return self.time
        return self.signals[name]


def output_rows(steps_done: int, every: int) -> npt.NDArray[np.int64]:
    """Base steps written with an output interval of ``every`` steps: ``0, k, 2k, ...`` and
    always the last one (a run's end, also an early end on a fault or a model's request)."""
    rows = np.arange(0, steps_done + 1, every, dtype=np.int64)
    if rows[-1] != steps_done:
        rows = np.append(rows, np.int64(steps_done))
    return rows
