"""Watching a run: one typed hook interface for progress bars, live views and statistics.

An observer subclasses :class:`RunObserver` and overrides the hooks it needs (each does
nothing by default), in the spirit of Hamilton's lifecycle hooks: the pipeline calls them in
this order — :meth:`~RunObserver.loaded` once the system is compiled,
:meth:`~RunObserver.before_run` just before the backend starts, :meth:`~RunObserver.progress`
while it runs (only when some observer :attr:`~RunObserver.wants_progress`: it costs a call
every few hundred steps), :meth:`~RunObserver.after_run` when the backend returned or raised,
and :meth:`~RunObserver.finished` with the outcome once the results are written. A run
abandoned at the step timeout ends the process: :meth:`~RunObserver.abandoned` is its last
word, after its results are written. A run that raised instead (a refusal, a progress
callback's exception) ends with :meth:`~RunObserver.failed`: what an observer holds (a
server's port, a half-written recording) is let go then, or the next run in the process
found the port taken (a bug hunt).

A live view (:mod:`fmionnx.pipeline.views`) also :attr:`~RunObserver.wants_feed`: the run
then hands it each camera frame as it is rendered (:meth:`~RunObserver.frame`) and the
recorded signals in batches of rows while it goes (:meth:`~RunObserver.rows`,
:mod:`fmionnx.pipeline.feed`); a run nobody watches this way records as it always does.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from fmionnx.pipeline.outcome import RunOutcome
    from fmionnx.pipeline.system import System
    from fmionnx.runtime.result import RunResult

LOG = logging.getLogger("fmionnx.pipeline")


@dataclass(frozen=True)
class RunStart:
    """What is about to run, and how."""

    system: System
    backend: str
    #: Where the run goes, for its first line (`` as ROS 2 nodes (lockstep)``); may be empty.
    where: str
    #: How it is kept safe (`` in a guarded process``); may be empty.
    how: str
    #: The steps run in a forked child: progress arrives through the parent, and a display
    #: must not keep a thread of its own across the fork (it refreshes on each update).
    guarded: bool
    #: The results folder (None: none).
    out: Path | None


@dataclass(frozen=True)
class Rows:
    """Recorded signals at some base steps, as a live view receives them: ``time`` (seconds)
    and one array per results column (values held between a component's steps, as in
    results.csv)."""

    time: npt.NDArray[np.float64]
    columns: dict[str, npt.NDArray[np.float64]]


class RunObserver:
    """Hooks on a run; override what you need (every hook does nothing by default)."""

    #: Whether :meth:`progress` is to be called (a progress bar on a terminal).
    wants_progress: bool = False
    #: How many base steps apart, at most (the run calls every observer at the finest).
    progress_every: int = 500
    #: Whether :meth:`frame` and :meth:`rows` are to be called (a live view).
    wants_feed: bool = False

    def loaded(self, system: System) -> None:
        """The system is compiled (``system.diagnostics`` holds its warnings)."""

    def before_run(self, start: RunStart) -> None:
        """The backend is about to start."""

    def progress(self, done: int, total: int, time: float) -> None:
        """``done`` of ``total`` base steps are done; simulated ``time`` reached."""

    def frame(self, component: str, port: str, time: float, image: npt.NDArray[np.generic]) -> None:
        """A camera frame of ``component.port`` rendered at simulated ``time`` (only with
        :attr:`wants_feed`; valid during the call only: copy what is kept)."""

    def rows(self, rows: Rows) -> None:
        """Recorded rows since the last call, in time order (only with :attr:`wants_feed`)."""

    def after_run(self) -> None:
        """The backend returned or raised (called whenever :meth:`before_run` was)."""

    def abandoned(self, result: RunResult, out: Path | None) -> None:
        """A step overran the step timeout in fmionnx's own process, or kept a stop signal
        waiting there: the results so far are written (into ``out``) and the process ends
        right after, with exit status 1 (a fault) or 128 + the signal's number."""

    def finished(self, outcome: RunOutcome) -> None:
        """The run's results are written; ``outcome`` holds them, the checks and the exit
        status."""

    def failed(self, error: BaseException) -> None:
        """The run raised ``error`` (it goes on to the caller) at any stage, possibly after
        :meth:`finished`: release what is held; nothing half-written is to be left."""


class Observers(RunObserver):
    """Several observers as one, in the order given."""

    def __init__(self, observers: Sequence[RunObserver]) -> None:
        self._all = tuple(observers)
        self.wants_progress = any(o.wants_progress for o in self._all)
        self.progress_every = min(
            (o.progress_every for o in self._all if o.wants_progress), default=500
        )
        self._fed = tuple(o for o in self._all if o.wants_feed)
        self.wants_feed = bool(self._fed)

    def loaded(self, system: System) -> None:
        """Each observer's :meth:`RunObserver.loaded`."""
        for observer in self._all:
            observer.loaded(system)

    def before_run(self, start: RunStart) -> None:
        """Each observer's :meth:`RunObserver.before_run`."""
        for observer in self._all:
            observer.before_run(start)

    def progress(self, done: int, total: int, time: float) -> None:
        """Each observer that wants progress."""
        for observer in self._all:
            if observer.wants_progress:
                observer.progress(done, total, time)

    def frame(self, component: str, port: str, time: float, image: npt.NDArray[np.generic]) -> None:
        """Each observer that wants the feed."""
        for observer in self._fed:
            observer.frame(component, port, time, image)

    def rows(self, rows: Rows) -> None:
        """Each observer that wants the feed."""
        for observer in self._fed:
            observer.rows(rows)

    def after_run(self) -> None:
        """Each observer's :meth:`RunObserver.after_run`, in reverse order (nested displays
        close inside out)."""
        for observer in reversed(self._all):
            observer.after_run()

    def abandoned(self, result: RunResult, out: Path | None) -> None:
        """Each observer's :meth:`RunObserver.abandoned`."""
        for observer in self._all:
            observer.abandoned(result, out)

    def finished(self, outcome: RunOutcome) -> None:
        """Each observer's :meth:`RunObserver.finished`."""
        for observer in self._all:
            observer.finished(outcome)

    def failed(self, error: BaseException) -> None:
        """Each observer's :meth:`RunObserver.failed`; one that raises in turn is logged, and
        the others still let go (``error`` is what the caller is to see)."""
        for observer in self._all:
            try:
                observer.failed(error)
            except Exception:
                LOG.warning("an observer failed to let go after the run raised", exc_info=True)
