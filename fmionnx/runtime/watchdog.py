"""The step timeout for components that run in fmionnx's own process.

An isolated component's step is timed by its proxy, which kills the child
(:mod:`fmionnx.runtime.isolated`). A component that runs in this process cannot be stopped
in the middle of a native call, so when one of its steps overruns the timeout the run is
*abandoned*: a watchdog thread hands the results recorded so far, with a fault naming the
component and the simulated time, to whoever can write them (the CLI writes the run's folder),
and then ends the process. That is the only way out of a model that never returns.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

#: How often the watchdog looks, at most (seconds).
POLL = 0.25

#: A step function of the master's schedule: ``step(t, h)``.
StepFunction = Callable[[float, float], None]


class Watchdog:
    """Times the steps it wraps; calls ``on_expiry(label, t)`` once when one overruns."""

    def __init__(self, timeout: float, on_expiry: Callable[[str, float], None]) -> None:
        self.timeout = timeout
        self._on_expiry = on_expiry
        #: The step in progress: (label, simulated time, monotonic start), or None.
        self._current: tuple[str, float, float] | None = None
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="fmionnx-watchdog", daemon=True)

    def wrap(self, label: str, step: StepFunction) -> StepFunction:
        """``step``, timed under ``label``."""
        clock = time.monotonic

        def timed(t: float, h: float) -> None:
            self._current = (label, t, clock())
            step(t, h)
            self._current = None

        return timed

    def start(self) -> None:
        """Start watching (a daemon thread: it never keeps the process alive)."""
        self._thread.start()

    def stop(self) -> None:
        """Stop watching; the thread ends within one poll."""
        self._stopped.set()

    def _watch(self) -> None:
        interval = min(POLL, self.timeout / 4)
        while not self._stopped.wait(interval):
            current = self._current
            if current is None:
                continue
            label, t, started = current
            if time.monotonic() - started > self.timeout and self._current is current:
                self._on_expiry(label, t)
                return
