"""Which step the guardian blames for a crash, from the marks in shared memory: the loop's
own mark is never cleared after its step, so a lane step in flight later in the sequential
order proves it stale (the loop hands steps to lanes in that order, after its own earlier
work); otherwise the earliest mark in the sequential order is blamed."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from fmionnx.runtime import guardian
from fmionnx.runtime.guardian import _Shared

STEP = 0.1
#: Work 0 runs on the loop thread, work 1 on a lane; their places in the order are 0 and 1.
DIRECTORY: dict[str, Any] = {"places": [0, 1]}
SYSTEM: Any = SimpleNamespace(run=SimpleNamespace(start=0.0, step=STEP, steps=100))


def _mark_loop(memory: _Shared, work: int, n: int) -> None:
    memory.cells[guardian._WORK] = work
    memory.cells[guardian._T] = n * STEP


def _mark_lane(memory: _Shared, work: int, n: int, place: int) -> None:
    base = guardian._LANES
    memory.cells[base + guardian._LANE_T] = n * STEP
    memory.cells[base + guardian._LANE_N] = n
    memory.cells[base + guardian._LANE_PLACE] = place
    memory.cells[base + guardian._LANE_WORK] = work


def test_a_lane_step_after_the_loops_finished_step_is_blamed(shared: _Shared) -> None:
    _mark_loop(shared, work=0, n=5)  # stepped, then the loop handed step 5 of work 1 on
    _mark_lane(shared, work=1, n=5, place=1)
    assert guardian._blamed(shared, DIRECTORY, SYSTEM)[:3] == (1, 5 * STEP, 5)


def test_the_loops_step_is_blamed_when_no_lane_is_in_flight(shared: _Shared) -> None:
    _mark_loop(shared, work=0, n=5)
    assert guardian._blamed(shared, DIRECTORY, SYSTEM)[:3] == (0, 5 * STEP, 5)


def test_an_earlier_lane_step_still_in_flight_is_blamed_first(shared: _Shared) -> None:
    _mark_loop(shared, work=0, n=6)  # may be under way while the lane's step 5 still runs
    _mark_lane(shared, work=1, n=5, place=1)
    assert guardian._blamed(shared, DIRECTORY, SYSTEM)[:3] == (1, 5 * STEP, 5)
