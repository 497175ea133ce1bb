"""The watch thread times every in-process run without being woken for each of them.

A sweep worker starts a run every millisecond; waking the watch thread at each start handed it
the GIL, and with both cores busy the run then waited for that thread to be scheduled. These
tests drive a watch thread of their own (not the process's) with real threads and clocks.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

from fmionnx.runtime import watchdog
from fmionnx.runtime.watchdog import Marker, Watchdog, _Watcher


class _Counted:
    """A watch thread of its own for the test's watchdogs, whose wake-ups by
    :meth:`_Watcher.add` are counted."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.watcher = _Watcher()
        monkeypatch.setattr(watchdog, "_watcher", lambda: self.watcher)
        self.notified = 0
        condition: Any = self.watcher._changed
        notify = condition.notify

        def counted(n: int = 1) -> None:
            self.notified += 1
            notify(n)

        condition.notify = counted


def _stuck(timeout: float) -> tuple[Watchdog, threading.Event, list[tuple[object, float]]]:
    """A watchdog over work that never moves on; the event is set when it fires."""
    work = object()
    marker = Marker()
    marker.work, marker.t = work, 1.5
    fired = threading.Event()
    seen: list[tuple[object, float]] = []

    def on_expiry(what: object, t: float, stop: int | None) -> None:
        assert stop is None  # an overrun: no stop signal came
        seen.append((what, t))
        fired.set()

    return Watchdog(timeout, marker, [work], on_expiry), fired, seen


def _settle(watcher: _Watcher, until: float) -> None:
    """Wait until the watch thread sleeps with its next wake-up at ``until`` (or later)."""
    deadline = time.monotonic() + 5
    while watcher._wakes < until and time.monotonic() < deadline:
        time.sleep(0.005)
    assert watcher._wakes >= until, "the watch thread never went to sleep"


def test_a_run_starting_while_the_thread_looks_soon_enough_does_not_wake_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    counted = _Counted(monkeypatch)
    _settle(counted.watcher, time.monotonic())  # idle, waking every POLL by itself
    dog, fired, seen = _stuck(timeout=1.0)  # looks every POLL: not sooner than the thread
    dog.start()
    assert fired.wait(30), "the overrun was never reported"
    assert counted.notified == 0
    assert seen[0][1] == 1.5


def test_an_overrun_sooner_than_the_threads_next_look_wakes_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(watchdog, "IDLE_POLLS", 0)  # idle: sleeps until woken
    counted = _Counted(monkeypatch)
    _settle(counted.watcher, float("inf"))
    dog, fired, _ = _stuck(timeout=0.2)
    dog.start()
    # Not woken, the thread would sleep for ever (IDLE_POLLS is 0): firing at all is the proof
    # (a bound on how soon failed on a loaded machine, where the thread waits for a core).
    assert fired.wait(30), "a sleeping watch thread was not woken for a new run"
    assert counted.notified == 1


def test_a_stopped_watchdog_never_fires(monkeypatch: pytest.MonkeyPatch) -> None:
    _Counted(monkeypatch)
    dog, fired, _ = _stuck(timeout=0.1)
    dog.start()
    dog.stop()
    assert not fired.wait(0.5)


def test_an_idle_watch_thread_stops_waking_by_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(watchdog, "POLL", 0.01)
    counted = _Counted(monkeypatch)
    _settle(counted.watcher, float("inf"))  # after IDLE_POLLS rounds of POLL
