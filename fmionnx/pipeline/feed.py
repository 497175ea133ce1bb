"""The live feed: what a run hands its live views while it goes (frames and recorded rows).

A view (:mod:`fmionnx.pipeline.views`) is an observer that
:attr:`~.observers.RunObserver.wants_feed`.
The pipeline then gives the master a recorder of its own making (through the master's
injection point, :class:`~fmionnx.runtime.instruments.Instruments`) and a frame sink, and
adds a :class:`Feeder` to the run's observers: riding on the loop's progress call, it reads
the rows recorded since it last looked, at most every :data:`FLUSH_EVERY` seconds of wall
time, and hands them on as :class:`~.observers.Rows`, one every
:func:`~fmionnx.results.channels.signal_stride` base steps (at most 100 a simulated second,
as the MCAP recording's signals). Rows are handed on a little behind the loop (by the
slowest component's period), so that a step still running on a worker thread of the
parallel schedule has recorded its outputs; the rest follows when the run ends. Nothing of
this exists in a run no view watches.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from fmionnx.core.runner import Buffer
from fmionnx.pipeline.observers import Observers, Rows, RunObserver
from fmionnx.results.channels import signal_stride
from fmionnx.runtime.recorder import Recorder

if TYPE_CHECKING:
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.runtime.recorder import FrameSink

#: Seconds of wall time between two batches of rows.
FLUSH_EVERY = 0.05


class Feeder(RunObserver):
    """Reads the rows the master records and hands them to the views (module docstring)."""

    wants_progress = True

    def __init__(self, system: CompiledSystem, views: Observers) -> None:
        run = system.run
        self.views = views
        self.recorder = Recorder()
        self.start, self.step = run.start, run.step
        self.stride = signal_stride(run.step)
        #: Rows are handed on this many base steps behind the loop (module docstring).
        self.lag = max((c.period_steps for c in system.components), default=1)
        self.progress_every = self.stride
        self._next = 0
        self._last = 0.0

    def progress(self, done: int, total: int, time_reached: float) -> None:
        """Hand on the rows up to ``done - lag`` when :data:`FLUSH_EVERY` has passed."""
        now = time.perf_counter()
        if now - self._last >= FLUSH_EVERY:
            self._last = now
            self.flush(done - self.lag)

    def flush(self, upto: int) -> None:
        """Hand on the rows at every stride-th base step from the next one up to ``upto``."""
        if upto < self._next:
            return
        steps = np.arange(self._next, upto + 1, self.stride, dtype=np.int64)
        self._next = int(steps[-1]) + self.stride
        columns = self.recorder.at(steps)
        times = (self.start + steps * self.step).astype(np.float64)
        self.views.rows(Rows(times, columns))


class FrameFanout:
    """One frame sink for the master: the recording's (``--record``) and the views'."""

    def __init__(self, sinks: list[FrameSink]) -> None:
        self._sinks = tuple(sinks)

    def frame(self, component: str, port: str, time: float, image: Buffer) -> None:
        """Each sink, in order."""
        for sink in self._sinks:
            sink.frame(component, port, time, image)
