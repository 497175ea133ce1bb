"""The guardian names what a model was doing when it took the run's process down.

Around each model's ``instantiate``, ``setup`` and ``terminate`` the guarded child stores the
phase in the shared control block (once per run, not per step); a crash in a step is told
by the loop's marker, and for a component stepped alone the fault names its FMI function.
The models here are real FMUs; the runner of one is wrapped to abort its process in the
phase under test (the guardian is the part under test, the runner its peer).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import fmionnx
from fmionnx.core.runner import Wiring
from fmionnx.core.types import Component
from fmionnx.kinds.registry import make_runner
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus

TWO = """
fmionnx: 1
name: two
run: {{stop: 0.5, step: 0.01}}
components:
  first: {{kind: fmu, path: {gain}, parameters: {{u: 0.25}}}}
  second: {{kind: fmu, path: {integrator}}}
connections:
  - first.y -> second.u
record: [first.y, second.x]
"""


class _AbortsIn:
    """A real runner that aborts its process when ``phase`` (a method name) is called."""

    def __init__(self, inner: Any, phase: str) -> None:
        self._inner, self._phase = inner, phase

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self._inner, name)
        if name == self._phase:

            def abort(*args: Any, **kwargs: Any) -> Any:
                os.abort()

            return abort
        return attribute


def _run(tmp_path: Path, fixture_fmu, phase: str) -> RunResult:
    path = tmp_path / "two.yaml"
    path.write_text(
        TWO.format(gain=fixture_fmu("Gain"), integrator=fixture_fmu("Integrator")),
        encoding="utf-8",
    )
    compiled = fmionnx.load(path).compiled

    def factory(component: Component, wiring: Wiring) -> Any:
        runner = make_runner(component, wiring)
        return _AbortsIn(runner, phase) if component.name == "second" else runner

    def run_fn(*, options: RunOptions) -> RunResult:
        return Master(compiled, options, factory).run()

    return run_guarded(compiled, run_fn, RunOptions())


@pytest.mark.parametrize(
    ("phase", "label"),
    [("instantiate", "loading and instantiating the model"), ("setup", "initialization")],
)
def test_a_crash_before_the_loop_names_the_component_and_what_it_was_doing(
    tmp_path: Path, fixture_fmu, phase: str, label: str
) -> None:
    result = _run(tmp_path, fixture_fmu, phase)
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "second"
    assert f"the model crashed with SIGABRT in {label}" in str(result.error)
    assert result.steps_done == 0
    assert result.error.time == 0.0


def test_a_crash_in_terminate_keeps_every_step_of_the_completed_loop(
    tmp_path: Path, fixture_fmu
) -> None:
    result = _run(tmp_path, fixture_fmu, "terminate")
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "second"
    assert "the model crashed with SIGABRT in terminate" in str(result.error)
    assert result.steps_done == 50  # the whole loop
    assert result.error.time == pytest.approx(0.5)
    assert result.time[-1] == pytest.approx(0.5)
    plain = fmionnx.load(tmp_path / "two.yaml").run(isolate="none")  # the same run, unguarded
    assert list(result.signals) == list(plain.signals) == ["first.y", "second.x"]
    for name, values in plain.signals.items():
        np.testing.assert_array_equal(result[name], values)


def test_a_crash_in_a_step_of_a_lone_fmu_names_its_fmi_function(fixture_fmu) -> None:
    from tests.backends.test_isolation import SEGFAULT

    system = fmionnx.load(fixture_fmu("Faulty"), step=0.01)
    chosen = system.with_overrides(params={"mode": SEGFAULT, "failAt": 0.2})
    result = run_guarded(chosen.compiled, chosen.run, RunOptions())
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert "crashed with SIGSEGV during its step, in fmi2DoStep or the calls" in str(result.error)
    assert result.error.time == pytest.approx(0.2)
    assert result.steps_done == 20


def test_a_process_ending_after_the_run_says_so_once(tmp_path: Path, fixture_fmu) -> None:
    """The run's process itself is the sentence's subject: said once, how it ended after."""
    path = tmp_path / "two.yaml"
    path.write_text(
        TWO.format(gain=fixture_fmu("Gain"), integrator=fixture_fmu("Integrator")),
        encoding="utf-8",
    )
    compiled = fmionnx.load(path).compiled

    def run_fn(*, options: RunOptions) -> RunResult:
        Master(compiled, options).run()
        os._exit(9)

    result = run_guarded(compiled, run_fn, RunOptions())
    assert result.status is RunStatus.FAULT
    assert str(result.error) == (
        "the run's process ended with exit status 9 after its models were terminated"
    )
    assert result.steps_done == 50
