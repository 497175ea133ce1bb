"""The step timeout for components that run in fmionnx's own process.

An isolated component's step is timed by its proxy, which kills the child
(:mod:`fmionnx.runtime.isolated`). A component that runs in this process cannot be stopped
in the middle of a native call, so when one of its steps overruns the timeout the run is
*abandoned*: a watchdog thread hands the results recorded so far, with a fault naming the
component and the simulated time, to whoever can write them (the CLI writes the run's folder),
and then ends the process. That is the only way out of a model that never returns.

The loop pays one store per step for this: it writes the work it is about to do into a
:class:`Marker`; the watchdog looks at it a few times a second and fires when the same work
has been under way for longer than the timeout. No step is wrapped or timed on the hot path.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Collection

#: How often the watchdog looks, at most (seconds).
POLL = 0.25


class Marker:
    """What the loop is doing: ``work`` (an object naming it) and the simulated time ``t``.

    Written by the loop before each step, read by the watchdog thread. Each (work, t) pair
    occurs once in a run, so an unchanged pair means the same step is still running.
    """

    __slots__ = ("t", "work")

    def __init__(self) -> None:
        self.work: object = None
        self.t = 0.0

    def lane_started(self, job: object) -> None:
        """A worker thread (a lane of the parallel schedule) starts ``job``'s step.

        Nothing to do here: the watchdog times a concurrent step when the loop joins it. The
        guardian's marker overrides this to know which steps are in flight on lanes.
        """

    def lane_ended(self, job: object) -> None:
        """``job``'s step on a lane returned or raised (see :meth:`lane_started`)."""


class Watchdog:
    """Calls ``on_expiry(work, t)`` once when the marked work stays the same too long.

    Only the work in ``watched`` is timed (isolated components time their own steps).
    """

    def __init__(
        self,
        timeout: float,
        marker: Marker,
        watched: Collection[object],
        on_expiry: Callable[[object, float], None],
    ) -> None:
        self.timeout = timeout
        self._marker = marker
        self._watched = {id(work) for work in watched}
        self._on_expiry = on_expiry
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="fmionnx-watchdog", daemon=True)

    def start(self) -> None:
        """Start watching (a daemon thread: it never keeps the process alive)."""
        self._thread.start()

    def stop(self) -> None:
        """Stop watching; the thread ends within one poll."""
        self._stopped.set()

    def _watch(self) -> None:
        interval = min(POLL, self.timeout / 4)
        seen: tuple[int, float] | None = None
        since = time.monotonic()
        while not self._stopped.wait(interval):
            marker = self._marker
            work, t = marker.work, marker.t
            now = time.monotonic()
            if (id(work), t) != seen:
                seen, since = (id(work), t), now
                continue
            if id(work) in self._watched and now - since > self.timeout:
                self._on_expiry(work, t)
                return
