"""The guardian with the parallel schedule: a crash in a step on a lane (a worker thread).

A lane's step runs while the loop's thread is busy with later work, so the work the loop
marked is not the one that crashed: the lane marks its own step in flight, and the guardian
blames the earliest step under way in the sequential order, keeping the sequential rows.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

import fmionnx
from fmionnx.core.runner import Runner, Wiring
from fmionnx.core.types import Component, PortRef
from fmionnx.kinds.registry import make_runner
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.backends.test_isolation import ABORT

BRANCHES = """
fmionnx: 1
name: branches
run: {{stop: 0.1, step: 0.01}}
components:
  a: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}, failAt: 0.05}}}}
  b: {{kind: fmu, path: {gain}, parameters: {{u: 0.25}}}}
  sink_a: {{kind: fmu, path: {gain}}}
  sink_b: {{kind: fmu, path: {gain}}}
connections:
  - a.y -> sink_a.u
  - b.y -> sink_b.u
"""


class _OnLane:
    """A real runner whose steps the parallel schedule hands to a lane (as an ONNX model's)."""

    releases_gil = True

    def __init__(self, inner: Runner) -> None:
        self._inner = inner

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


class _SlowAt:
    """A real runner whose step from ``t`` takes a while: the loop is there when a lane crashes."""

    releases_gil = False

    def __init__(self, inner: Runner, t: float) -> None:
        self._inner, self._t = inner, t

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def step(self, t: float, h: float) -> None:
        if t >= self._t - 1e-12:
            time.sleep(0.3)
        self._inner.step(t, h)


def _factory(component: Component, wiring: Wiring) -> Any:
    runner = make_runner(component, wiring)
    if component.name == "a":
        return _OnLane(runner)
    if component.name == "b":
        return _SlowAt(runner, 0.05)
    return runner


def _run(path: Path, schedule: str, record: tuple[PortRef, ...] | None = None) -> RunResult:
    compiled = fmionnx.load(path).compiled

    def run_fn(*, options: RunOptions) -> RunResult:
        return Master(compiled, options, _factory).run()

    return run_guarded(compiled, run_fn, RunOptions(schedule=schedule, record=record))


def test_a_crash_on_a_lane_names_its_component_and_keeps_the_sequential_rows(
    fixture_fmu, write_system
) -> None:
    path = write_system(BRANCHES.format(faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=ABORT))  # fmt: skip
    sequential = _run(path, "sequential")
    parallel = _run(path, "parallel")
    for result in (sequential, parallel):
        assert result.status is RunStatus.FAULT
        assert result.error is not None
        assert result.error.component == "a", result.error
        assert "crashed with SIGABRT" in str(result.error)
        assert result.error.time == 0.05
    assert parallel.steps_done == sequential.steps_done == 5
    assert list(parallel.signals) == list(sequential.signals)
    for name, column in sequential.signals.items():
        np.testing.assert_array_equal(parallel.signals[name], column, err_msg=name)
    np.testing.assert_array_equal(parallel.time, sequential.time)


RAMPED = """
fmionnx: 1
name: ramped
run: {{stop: 0.1, step: 0.01}}
components:
  ramp: {{kind: fmu, path: {integrator}, parameters: {{u: 1.0}}}}
  a: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}, failAt: 0.05}}}}
  b: {{kind: fmu, path: {gain}}}
  sink_a: {{kind: fmu, path: {gain}}}
  sink_b: {{kind: fmu, path: {gain}}}
connections:
  - ramp.x -> b.u
  - a.y -> sink_a.u
  - b.y -> sink_b.u
"""


def test_inputs_recorded_by_the_loop_after_a_lane_crashed_are_not_kept(
    fixture_fmu, write_system
) -> None:
    """The loop went on to b (after a in the order) while a crashed on its lane: b's inputs
    at that step, which the sequential run never recorded, are not in the salvaged table."""
    path = write_system(
        RAMPED.format(
            integrator=fixture_fmu("Integrator"), faulty=fixture_fmu("Faulty"),
            gain=fixture_fmu("Gain"), mode=ABORT,
        )
    )  # fmt: skip
    record = (PortRef("b", "u"), PortRef("b", "y"), PortRef("a", "y"))
    sequential = _run(path, "sequential", record)
    parallel = _run(path, "parallel", record)
    for result in (sequential, parallel):
        assert result.error is not None
        assert result.error.component == "a", result.error
    assert parallel.steps_done == sequential.steps_done == 5
    assert list(parallel.signals) == list(sequential.signals) == ["b.u", "b.y", "a.y"]
    for name, column in sequential.signals.items():
        np.testing.assert_array_equal(parallel.signals[name], column, err_msg=name)
