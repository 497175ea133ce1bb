"""The master's injection points: what it records into, what it marks, how runners are made.

The in-process master builds a :class:`~fmionnx.runtime.recorder.Recorder` for the signals, a
:class:`~fmionnx.runtime.watchdog.Marker` naming the step under way, and one runner per
component from its runner factory. A caller that must see those from outside the loop hands
its own through :class:`Instruments` (in ``RunOptions.instruments``) instead of patching the
master: the guardian's child records into shared memory and marks there, and wraps the
factory so that each model's phases (instantiate, setup, terminate) are marked too
(:mod:`fmionnx.runtime.guardian`). Live views and statistics attach the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from fmionnx.core.runner import RunnerFactory
from fmionnx.runtime.recorder import Recorder
from fmionnx.runtime.watchdog import Marker


@dataclass(frozen=True)
class Instruments:
    """Makers of the master's recorder and marker, and a wrapper of its runner factory."""

    recorder: Callable[[], Recorder] = Recorder
    marker: Callable[[], Marker] = Marker
    #: Wraps the factory the master ends up with (isolation included); None: as it is.
    runners: Callable[[RunnerFactory], RunnerFactory] | None = None
    #: Whether the watchdog abandons a run whose main thread a model keeps from a stop
    #: signal (:mod:`.stopnotice`); a guarded child's guardian stops it instead.
    notices_stops: bool = True


#: The master's own: a private recorder and marker, runners as the factory makes them.
PLAIN = Instruments()
