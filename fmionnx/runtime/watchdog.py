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

One thread per process does the looking for every run of that process (:class:`_Watcher`),
started with the first run and kept: a sweep worker runs cases of a millisecond one after the
other, and a thread started and ended per run cost it more than the case itself when another
worker kept the other core busy (``Thread.start`` waits until the new thread has run). For the
same reason a run that starts does not wake the thread when it will look soon enough anyway:
waking it hands it the GIL, and with every core busy the run then waits for the woken thread
to be scheduled (an eighth of a short case's time on a two-core sweep).

The timeout holds for every phase of a component, not only its steps (docs/security.md):
:class:`PhaseWatch` wraps the runner factory so that loading a model, instantiating,
initializing and terminating it are watched too, by the same watchdog, each call marked on
the run's marker while it runs (two stores per call, none per step). A runner that can be
stopped from another thread (:class:`~fmionnx.core.runner.Interruptible`: onnxruntime's
terminate flag) is asked to stop first; the call then raises a fault and the run ends as
any other faulted run does, in this process. Only native code that cannot be stopped makes
the run be abandoned.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Collection, Mapping
from typing import Any

from fmionnx.core.processlocal import ProcessLocal
from fmionnx.core.runner import Interruptible, Runner, RunnerFactory, Wiring
from fmionnx.core.types import Component
from fmionnx.runtime.stopnotice import ACTED_GRACE, STOP_GRACE, StopNotice
from fmionnx.runtime.stopping import holding_stops

#: How often the watchdog looks, at most (seconds).
POLL = 0.25
#: Rounds of :data:`POLL` the watch thread stays awake with nothing to watch.
IDLE_POLLS = 8
#: Seconds an interrupted call has to come back (with its fault) before the run is abandoned.
INTERRUPT_GRACE = 2.0


class Marker:
    """What the loop is doing: ``work`` (an object naming it) and the simulated time ``t``.

    Written by the loop before each step, read by the watchdog thread. Each (work, t) pair
    occurs once in a run, so an unchanged pair means the same step is still running.
    """

    __slots__ = ("t", "work")

    def __init__(self) -> None:
        self.work: object = None
        self.t = 0.0

    def t_address(self) -> int:
        """Where native code may store ``t`` itself; 0: nowhere (``t`` is a Python float, set
        by the loop between the native loop's chunks: see :mod:`fmionnx.runtime.native.bulk`).
        """
        return 0

    def lane_started(self, job: object) -> None:
        """A worker thread (a lane of the parallel schedule) starts ``job``'s step.

        Nothing to do here: the watchdog times a concurrent step when the loop joins it. The
        guardian's marker overrides this to know which steps are in flight on lanes.
        """

    def lane_ended(self, job: object) -> None:
        """``job``'s step on a lane returned or raised (see :meth:`lane_started`)."""


class Watchdog:
    """Calls ``on_expiry(work, t, stop)`` once when the marked work stays the same too long
    (``stop`` None), or keeps a stop signal waiting (``stop`` its number; see :attr:`notice`);
    it returns False to have the watching go on (the loop's thread ends the run itself).

    Only the work in ``watched`` is timed (isolated components time their own steps).
    ``interrupt(work, timeout)``, when given, is tried first: True when the work was asked to
    stop (:class:`Interrupter`); ``on_expiry`` is then called only if it has not come back
    within :data:`INTERRUPT_GRACE` seconds.
    """

    def __init__(
        self,
        timeout: float,
        marker: Marker,
        watched: Collection[object],
        on_expiry: Callable[[object, float, int | None], bool | None],
        interrupt: Callable[[object, float], bool] | None = None,
    ) -> None:
        self.timeout = timeout
        #: Seconds between looks.
        self.interval = min(POLL, timeout / 4)
        self._marker = marker
        self._watched = {id(work) for work in watched}
        self._on_expiry = on_expiry
        self._interrupt = interrupt
        self._seen: tuple[int, float] | None = None
        self._since = 0.0
        #: When this watchdog looks next (monotonic seconds).
        self.due = 0.0
        self._overrun: tuple[object, float] | None = None
        #: Set by :meth:`stop` (a plain flag, not an Event: an Event's lock and condition
        #: cost a short sweep case more than the watching itself).
        self._stopped = False
        #: Stop signals seen while the main thread may be stuck (set for a run on the main
        #: thread: :mod:`.stopnotice`); the one that made :meth:`look` fire.
        self.notice: StopNotice | None = None
        self._stop: int | None = None

    def watch(self, work: object) -> None:
        """Time ``work`` too (a phase made after the watchdog was)."""
        self._watched.add(id(work))

    def start(self) -> None:
        """Start watching, on this process's watch thread (a daemon: it never keeps the
        process alive)."""
        self._seen = None
        self._since = time.monotonic()
        self.due = self._since + self.interval
        self._stopped = False
        _watcher().add(self)

    def stop(self) -> None:
        """Stop watching: :meth:`look` is not called again once this returns."""
        self._stopped = True  # first: a fire that re-adds this watchdog sees it (see fire)
        _watcher().discard(self)

    def look(self, now: float) -> bool:
        """One look at the marker at ``now``; True when the work has overrun (fire), or has
        kept a stop signal waiting for :data:`~.stopnotice.STOP_GRACE` (the main thread is
        stuck in it: a Python signal handler cannot run until the call returns)."""
        self.due = now + self.interval
        notice = self.notice
        signum = notice.poll(now) if notice is not None else None
        work, t = self._marker.work, self._marker.t
        if (id(work), t) != self._seen:
            self._seen, self._since = (id(work), t), now
            return False
        if id(work) not in self._watched:
            return False
        stop = signum if notice is not None and not holding_stops() else None
        if stop is not None and notice is not None and self._kept(notice, now):
            self._overrun, self._stop = (work, t), stop
            return True
        if now - self._since > self.timeout:  # a stop that came first is still the reason
            self._overrun, self._stop = (work, t), stop
            return True
        return False

    def _kept(self, notice: StopNotice, now: float) -> bool:
        """Whether the marked call kept a stop from ending the run: pending (the main thread
        ran no Python since it came) for :data:`STOP_GRACE`, or acted on and still the same
        call after :data:`ACTED_GRACE` (the loop waits for it: a hung step on a lane)."""
        since = notice.pending_since
        if since is not None and now - max(since, self._since) >= STOP_GRACE:
            return True
        return now - max(notice.first_at, self._since) >= ACTED_GRACE

    def fire(self) -> None:
        """Stop the overrun :meth:`look` saw, or report it (the master's handler then ends
        the process)."""
        assert self._overrun is not None
        work, t = self._overrun
        # A stop is not interrupted: the fault an interrupted call raises would meet the stop
        # held for the main thread on its way out; abandoned, the run says it was stopped.
        interrupt = self._interrupt if self._stop is None else None
        interrupted = interrupt is not None and interrupt(work, self.timeout)
        # The run goes on when the interrupted work raised a fault that the run handles, or
        # when the handler of a stop declines (the loop's thread came back and ends the run).
        if (interrupted and self._came_back(work, t)) or self._on_expiry(
            work, t, self._stop
        ) is False:
            # Watch on, unless the watching was stopped meanwhile (checked after adding, so
            # that a stop between the two cannot leave this watchdog watching).
            _watcher().add(self)
            if self._stopped:
                _watcher().discard(self)

    def _came_back(self, work: object, t: float) -> bool:
        """Whether the interrupted work ended (the marker moved on, or the watching was
        stopped: the run is ending with the fault) within :data:`INTERRUPT_GRACE`."""
        deadline = time.monotonic() + INTERRUPT_GRACE
        while time.monotonic() < deadline:
            if self._stopped or self._marker.work is not work or self._marker.t != t:
                return True
            time.sleep(0.01)
        return False


class Phase:
    """One component's call outside the loop: loading, instantiating, initializing or
    terminating it (what :func:`timed_phases` marks while the call runs)."""

    __slots__ = ("name", "what")

    def __init__(self, name: str, what: str) -> None:
        #: The component's name.
        self.name = name
        #: The call, as the subject of a sentence (``its initialization``).
        self.what = what


#: The runner calls timed besides the steps: (method, what the call is, said of the model).
PHASES = (
    ("instantiate", "its loading and instantiation"),
    ("setup", "its initialization"),
    ("terminate", "its termination"),
)
#: What making the runner is (a kind may load the model there already).
LOADING = "its loading"


def overrun_text(work: object, timeout: float) -> str:
    """The start of a fault about ``work`` overrunning ``timeout`` (a step or a phase)."""
    what = work.what if isinstance(work, Phase) else "a step"
    return f"{what} did not return within {timeout:g} s (the step timeout)"


class Interrupter:
    """``interrupt(work, timeout)`` for a :class:`Watchdog`: asks the runners doing ``work``
    to stop, when every one of them can (:class:`~fmionnx.core.runner.Interruptible`)."""

    def __init__(self, runners: Mapping[str, Runner]) -> None:
        self._runners = runners

    def __call__(self, work: object, timeout: float) -> bool:
        names = tuple(getattr(work, "members", ()) or ()) or (getattr(work, "name", ""),)
        stoppable: list[Interruptible] = []
        for name in names:
            runner: object = self._runners.get(name)
            if not isinstance(runner, Interruptible):
                return False
            stoppable.append(runner)
        reason = f"{overrun_text(work, timeout)}; it was stopped"
        for each in stoppable:
            each.interrupt(reason)
        return True


class PhaseWatch:
    """Marks the calls of in-process runners outside the loop for the run's watchdog:
    loading a model (making its runner), ``instantiate``, ``setup`` and ``terminate``.

    :meth:`factory` wraps a runner factory; every call it times stores a :class:`Phase` and
    the simulated time (``clock()``) on the run's marker and clears the work when the call
    returns: two stores and no lock, so a sweep's short cases pay next to nothing. The
    run's watchdog (started before the first of these calls, stopped after the last) then
    times them as it times steps: interrupted when the runner can be, else reported.
    """

    def __init__(self, watchdog: Watchdog, marker: Marker, clock: Callable[[], float]) -> None:
        self._watchdog = watchdog
        self._marker = marker
        self._clock = clock
        #: Every call's phase, kept: the watchdog tells calls apart by their phase's id.
        self._calls: list[Phase] = []

    def factory(self, make: RunnerFactory) -> RunnerFactory:
        """``make``, with its runners' loading and life-cycle calls marked."""

        def make_timed(component: Component, wiring: Wiring) -> Runner:
            name = component.name
            runner: Runner = self._timed(name, LOADING, make, component, wiring)
            for method, what in PHASES:
                call = getattr(runner, method)

                def timed_call(*args: Any, what: str = what, call: Any = call) -> Any:
                    return self._timed(name, what, call, *args)

                try:
                    setattr(runner, method, timed_call)
                except (AttributeError, TypeError):  # a runner with slots: left untimed
                    continue
            return runner

        return make_timed

    def _timed(self, name: str, what: str, call: Callable[..., Any], *args: Any) -> Any:
        phase = Phase(name, what)
        self._calls.append(phase)
        self._watchdog.watch(phase)
        marker = self._marker
        marker.work, marker.t = phase, self._clock()
        try:
            return call(*args)
        finally:
            marker.work = None


class _Watcher:
    """The one thread of a process that looks at every running :class:`Watchdog`.

    It sleeps until the soonest look is due. With nothing to watch it keeps waking every
    :data:`POLL` for :data:`IDLE_POLLS` rounds before it sleeps until woken: runs that follow
    each other closely (a sweep's cases) then find it awake soon enough and need not wake it.
    """

    def __init__(self) -> None:
        self._active: list[Watchdog] = []
        self._changed = threading.Condition()
        #: When the thread wakes next by itself (monotonic seconds; inf: only when woken).
        self._wakes = math.inf
        self._thread = threading.Thread(target=self._watch, name="fmionnx-watchdog", daemon=True)
        self._thread.start()

    def add(self, watchdog: Watchdog) -> None:
        with self._changed:
            self._active.append(watchdog)
            if watchdog.due < self._wakes:
                self._changed.notify()

    def discard(self, watchdog: Watchdog) -> None:
        # Under the lock: a look in progress finishes first, and none starts after this.
        with self._changed:
            if watchdog in self._active:
                self._active.remove(watchdog)

    def _watch(self) -> None:
        idle = 0
        with self._changed:
            while True:
                now = time.monotonic()
                if not self._active:
                    idle += 1
                    self._sleep(now, now + POLL if idle <= IDLE_POLLS else math.inf)
                    continue
                idle = 0
                soonest = min(w.due for w in self._active)
                if soonest > now:
                    self._sleep(now, soonest)
                    continue
                for watchdog in [w for w in self._active if w.due <= now]:
                    if watchdog not in self._active:  # stopped while a handler ran unlocked
                        continue
                    if watchdog.look(now):
                        self._active.remove(watchdog)
                        self._changed.release()  # the handler may take long or never return
                        try:
                            watchdog.fire()
                        finally:
                            self._changed.acquire()

    def _sleep(self, now: float, until: float) -> None:
        """Wait, holding nothing, until ``until`` or until :meth:`add` wakes the thread."""
        self._wakes = until
        try:
            self._changed.wait(None if until == math.inf else until - now)
        finally:
            self._wakes = -math.inf  # awake: every add notifies until the next sleep


#: This process's watch thread (a forked child starts its own).
_WATCHER: ProcessLocal[_Watcher] = ProcessLocal()


def _watcher() -> _Watcher:
    return _WATCHER.get_or_make(_Watcher)


def watch_thread() -> threading.Thread | None:
    """This process's watch thread, if it runs. A fork may leave it behind: it holds no lock
    a child needs (a forked child makes a watcher of its own)."""
    watcher = _WATCHER.get()
    return None if watcher is None else watcher._thread
