"""A model that asks to end the simulation ends the run normally (issue 13).

FMI 2 co-simulation: ``fmi2DoStep`` returns ``fmi2Discard`` and ``fmi2GetBooleanStatus
(fmi2Terminated)`` is true (the ``Faulty`` fixture, mode 10); FMI 3: ``fmi3DoStep`` sets
``terminateSimulation`` (the ``Vector3`` fixture's ``stopAt``). The run ends at the end of
that step with status ``completed``, its outputs in the last row, and ``ended_by`` saying who
ended it; in Python, in the native kernel and isolated alike. A plain ``fmi2Discard`` (mode 2)
stays a fault (``test_fmu_runs``, ``test_native_group``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.runtime.result import EndedBy, RunOptions, RunResult, RunStatus

TERMINATE = 10
ENDED = EndedBy("bad", 0.31, "the FMU requested termination")


def _system(fixture_fmu, write_system, mode: int = TERMINATE) -> Path:
    # bad and tail form one native group; the ramp makes every step's values differ
    return write_system(
        f"""
fmionnx: 1
name: ending
run: {{stop: 1.0, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{u: {{ramp: {{slope: 2}}}}}}}}
  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  tail: {{kind: fmu, path: {fixture_fmu("Gain")}}}
connections:
  - src.u -> bad.u
  - bad.y -> tail.u
record: [bad.u, bad.y, tail.y]
"""
    )


def _run(path: Path, monkeypatch: pytest.MonkeyPatch, native: str, **options: object) -> RunResult:
    with monkeypatch.context() as patch:
        patch.setenv("FMIONNX_NATIVE", native)
        return fmionnx.load(path).run(options=RunOptions(**options))  # type: ignore[arg-type]


def _assert_ended_normally(result: RunResult) -> None:
    assert result.status is RunStatus.COMPLETED
    assert result.error is None
    assert result.ended_by == ENDED
    assert result.steps_done == 31
    assert result.time[-1] == pytest.approx(0.31)
    # the terminating step (from 0.3) completed: its output is the last row
    assert result["bad.y"][-1] == result["bad.u"][-1]
    assert result["bad.y"][-1] != result["bad.y"][-2]
    # tail comes after bad in the order: it did not step at 0.3 and holds its value
    assert result["tail.y"][-1] == result["tail.y"][-2]


def test_fmi2_termination_ends_the_run_normally_in_python_and_natively(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _system(fixture_fmu, write_system)
    python = _run(path, monkeypatch, "0")
    native = _run(path, monkeypatch, "1")
    assert native.details["native_components"] == 2
    for result in (python, native):
        _assert_ended_normally(result)
    for name, values in python.signals.items():
        np.testing.assert_array_equal(native.signals[name], values)


def test_fmi2_termination_crosses_the_process_boundary_of_an_isolated_fmu(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _system(fixture_fmu, write_system)
    python = _run(path, monkeypatch, "0")
    isolated = _run(path, monkeypatch, "1", isolate=frozenset({"bad", "tail"}))
    _assert_ended_normally(isolated)
    for name, values in python.signals.items():
        np.testing.assert_array_equal(isolated.signals[name], values)


def test_a_plain_discard_is_still_a_fault(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    for native in ("0", "1"):
        result = _run(_system(fixture_fmu, write_system, mode=2), monkeypatch, native)
        assert result.status is RunStatus.FAULT
        assert result.ended_by is None
        assert "fmi2DoStep returned Discard" in str(result.error)


def test_fmi3_terminate_simulation_ends_the_run_at_the_end_of_that_step(fixture_fmu) -> None:
    system = fmionnx.load(fixture_fmu("Vector3"), step=0.1)
    result = system.run(isolate="none", stop_time=2.0, params={"stopAt": 0.5})
    assert result.status is RunStatus.COMPLETED
    assert result.ended_by is not None
    assert (result.ended_by.component, result.ended_by.time) == (system.compiled.name, 0.5)
    assert result.steps_done == 5
    assert result["count"][-1] == 5


def test_cli_reports_who_ended_the_run_and_exits_0(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    path = _system(fixture_fmu, write_system)
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "ended at t=0.31 s by component `bad`: the FMU requested termination" in result.output
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert info["status"] == "completed"
    assert info["ended_by"] == {
        "component": "bad",
        "time": 0.31,
        "reason": "the FMU requested termination",
    }
    assert info["error"] is None
    rows = (out / "results.csv").read_text(encoding="utf-8").splitlines()
    assert rows[-1].startswith("0.31,")
    assert len(rows) == 1 + 32


@pytest.mark.parametrize("solver", ["euler", "cvode"])
def test_fmi2_model_exchange_termination_ends_the_run(
    fixture_fmu, write_system, solver: str
) -> None:
    # Integrator (ME) asks to terminate from fmi2CompletedIntegratorStep once x >= xStop
    path = write_system(
        f"""
fmionnx: 1
name: me_ending
run: {{stop: 2.0, step: 0.1}}
components:
  integ: {{kind: fmu, path: {fixture_fmu("Integrator")}, interface: me, solver: {solver},
           parameters: {{u: 1.0, xStop: 0.45}}}}
record: [integ.x]
"""
    )
    result = fmionnx.load(path).run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert result.ended_by is not None
    assert result.ended_by.component == "integ"
    # the end of the step in which x passed xStop (the model sees it one Euler step later)
    assert 0.45 < result.ended_by.time < 0.65
    assert result.time[-1] == result.ended_by.time
    assert result.steps_done < 20
    assert result["integ.x"][-1] >= 0.45
