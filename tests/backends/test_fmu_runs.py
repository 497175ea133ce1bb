"""FMU runs through the master match fmpy, are deterministic, hold slow values, stop on faults."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

import fmionnx
from fmionnx.kinds.fmu.fmi2 import Fmi2CoSimulation, Fmi2ModelExchange
from fmionnx.kinds.fmu.fmi3 import Fmi3CoSimulation, Fmi3ModelExchange
from fmionnx.kinds.fmu.runner import FmuRunner
from fmionnx.kinds.registry import make_runner
from fmionnx.results import write_results
from fmionnx.runtime.result import RunStatus
from tests.conftest import built_model


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_single_fmi2_fmu_matches_fmpy_simulate(fixture_fmu, interface: str) -> None:
    fmu = fixture_fmu("Integrator")
    ours = fmionnx.load(fmu, interface=interface, step=0.01).run(
        isolate="none", stop_time=1.0, params={"u": 2.0, "x0": 0.5}
    )
    theirs = simulate_fmu(
        str(fmu),
        fmi_type="CoSimulation" if interface == "cs" else "ModelExchange",
        stop_time=1.0,
        output_interval=0.01,
        step_size=0.01 if interface == "cs" else None,
        start_values={"u": 2.0, "x0": 0.5},
        output=["x"],
    )
    assert ours.status is RunStatus.COMPLETED
    np.testing.assert_allclose(ours.time, theirs["time"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours["x"], theirs["x"], rtol=1e-4, atol=1e-6)
    assert ours["x"][-1] == pytest.approx(2.5, rel=1e-4)


def test_fmi3_array_fmu_matches_fmpy_simulate(fixture_fmu) -> None:
    fmu = fixture_fmu("Vector3")
    ours = fmionnx.load(fmu, step=0.1).run(
        isolate="none", stop_time=1.0, params={"u": [1.0, -2.0, 3.0], "k": 1.5}
    )
    theirs = simulate_fmu(
        str(fmu),
        stop_time=1.0,
        output_interval=0.1,
        start_values={"u": [1.0, -2.0, 3.0], "k": 1.5},
        output=["y", "count"],
    )
    for i in range(3):
        np.testing.assert_array_equal(ours[f"y[{i}]"][1:], theirs["y"][1:, i])
    np.testing.assert_array_equal(ours["count"][1:], theirs["count"][1:])


def test_single_fmu_columns_use_variable_names(fixture_fmu, tmp_path: Path) -> None:
    system = fmionnx.load(fixture_fmu("Gain"), step=0.1)
    result = system.run(isolate="none", stop_time=0.5)
    write_results(result, system.compiled, tmp_path)
    header = (tmp_path / "results.csv").read_text().splitlines()[0]
    assert header == "time,y,w[1],w[2],w[3]"


def _chain(fixture_fmu, write_system, *, interface: str = "cs") -> Path:
    return write_system(
        f"""
fmionnx: 1
name: chain
run: {{stop: 1.0, step: 0.01}}
components:
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}, interface: {interface}, parameters: {{u: 1.5, k: 3.0}}}}
  integ: {{kind: fmu, path: {fixture_fmu("Integrator")}, interface: {interface}, period: 0.05}}
connections:
  - gain.y -> integ.u
record: [gain.y, integ.x]
"""
    )


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_chain_integrates_the_gain_output(fixture_fmu, write_system, interface: str) -> None:
    path = _chain(fixture_fmu, write_system, interface=interface)
    result = fmionnx.load(path).run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert result["integ.x"][-1] == pytest.approx(4.5, rel=1e-6)


def test_slower_component_values_are_held_between_its_steps(fixture_fmu, write_system) -> None:
    path = _chain(fixture_fmu, write_system)
    result = fmionnx.load(path).run(isolate="none", stop_time=0.2)
    x = result["integ.x"]
    # integ steps every 5 base steps: its output changes only at rows 5, 10, 15, 20
    changes = np.flatnonzero(np.diff(x)) + 1
    assert changes.tolist() == [5, 10, 15, 20]
    np.testing.assert_allclose(x[[0, 4, 5, 9, 10]], [0.0, 0.0, 0.225, 0.225, 0.45])


def test_same_system_twice_gives_bit_identical_results_csv(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    path = _chain(fixture_fmu, write_system, interface="me")
    texts = []
    for attempt in ("a", "b"):
        system = fmionnx.load(path)
        write_results(system.run(isolate="none"), system.compiled, tmp_path / attempt)
        texts.append((tmp_path / attempt / "results.csv").read_bytes())
    assert texts[0] == texts[1]
    assert len(texts[0].splitlines()) == 102


def _faulty(fixture_fmu, write_system, mode: int) -> Path:
    return write_system(
        f"""
fmionnx: 1
name: faulty
run: {{stop: 1.0, step: 0.01}}
components:
  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}}}
connections:
  - bad.y -> gain.u
"""
    )


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (0, r"component `bad` at t=0\.3 s: fmi2DoStep returned Error"),
        (2, r"component `bad` at t=0\.3 s: fmi2DoStep returned Discard"),
        (1, r"component `bad`, port `y` at t=0\.\d+ s: NaN on the connection `bad\.y -> gain\.u`"),
    ],
)
def test_fmu_fault_stops_the_run_with_partial_results(
    fixture_fmu, write_system, mode: int, message: str
) -> None:
    result = fmionnx.load(_faulty(fixture_fmu, write_system, mode)).run(isolate="none")
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "bad"
    with pytest.raises(type(result.error), match=message):
        raise result.error
    assert 25 <= result.steps_done <= 30
    assert result["bad.y"].size == result.steps_done + 1
    assert np.isfinite(result["bad.y"][:-1]).all()


@pytest.mark.parametrize(
    ("model", "interface", "expected"),
    [
        ("Gain", "cs", Fmi2CoSimulation),
        ("Gain", "me", Fmi2ModelExchange),
        ("Vector3", "cs", Fmi3CoSimulation),
        ("ReadOdometry3.fmu", "me", Fmi3ModelExchange),
    ],
)
def test_runner_class_follows_fmi_version_and_interface_type(
    fixture_fmu, model: str, interface: str, expected: type
) -> None:
    path = built_model(model) if model.endswith(".fmu") else fixture_fmu(model)
    component = fmionnx.load(path, interface=interface).compiled.components[0]
    runner = make_runner(component)
    assert type(runner) is expected
    assert isinstance(runner, FmuRunner)
