"""ReadOdometry3, the FMI 3.0 build of ReadOdometry: valid, same pose as the FMI 2 build, runs."""

from __future__ import annotations

import importlib.util
import json
import shutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.runtime.result import RunStatus
from tests.conftest import REPO, built_model
from tests.models.test_read_odometry import angle_error, euler_to_quaternion, numpy_yaw

INPUTS = ("qw", "qx", "qy", "qz", "x", "y")
OUTPUTS = ("posX", "posY", "theta")


def special_inputs() -> np.ndarray:
    """Rows of (qw, qx, qy, qz, x, y): yaw just below +pi and above -pi, exactly pi, tilted and
    non-unit quaternions (scaled by 1e-3 and 250), the zero quaternion and a generic pose."""
    quats = [
        euler_to_quaternion(0.0, 0.0, np.pi - 1e-12),
        euler_to_quaternion(0.2, -0.1, -np.pi + 1e-9),
        np.array([0.0, 0.0, 0.0, 1.0]),  # yaw exactly pi
        np.array([1e-9, 0.0, 0.0, -1.0]),  # yaw just above -pi
        1e-3 * euler_to_quaternion(0.1, 0.3, 2.0),
        250.0 * euler_to_quaternion(-0.2, 0.1, np.pi - 1e-6),
        np.array([0.3, -0.2, 0.1, 0.9]),  # non-unit, |q| ~ 0.98
        np.zeros(4),
    ]
    positions = np.array([[1.5, -2.0], [0.0, 0.0], [-3.25, 7.0], [1e6, -1e-6]] * 2)
    return np.hstack([np.array(quats), positions])


def _simulate(name: str, fmi_type: str, rows: np.ndarray) -> np.ndarray:
    """fmpy.simulate_fmu with one input row per 0.1 s step; outputs at every step.

    The last row is held one step longer: co-simulation records a step's outputs at its end,
    so without it the last input would never reach an output.
    """
    rows = np.vstack([rows, rows[-1:]])
    dtype = [("time", np.float64)] + [(n, np.float64) for n in INPUTS]
    signals = np.array([(0.1 * k, *row) for k, row in enumerate(rows)], dtype=np.dtype(dtype))
    result = simulate_fmu(
        str(built_model(name)),
        fmi_type=fmi_type,
        stop_time=0.1 * (len(rows) - 1),
        step_size=0.1 if fmi_type == "CoSimulation" else None,
        output_interval=0.1,
        input=signals,
        output=list(OUTPUTS),
    )
    return np.column_stack([result[n] for n in OUTPUTS])


def _models_build() -> ModuleType:
    """models/build.py as a module, under a name that cannot shadow the `build` package."""
    spec = importlib.util.spec_from_file_location("models_build", REPO / "models" / "build.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def slave() -> Iterator[tuple[FMU3Slave, dict[str, int]]]:
    path = built_model("ReadOdometry3.fmu")
    description = read_model_description(str(path))
    unzipped = extract(str(path))
    fmu = FMU3Slave(guid=description.guid, unzipDirectory=unzipped, modelIdentifier="ReadOdometry3")
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    yield fmu, {v.name: v.valueReference for v in description.modelVariables}
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(unzipped, ignore_errors=True)


def test_fmi3_build_passes_fmpy_validation() -> None:
    assert validate_fmu(str(built_model("ReadOdometry3.fmu"))) == []


def test_inspect_reads_fmi3_with_ports_units_and_feedthrough(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(
        app,
        ["inspect", str(built_model("ReadOdometry3.fmu")), "--format", "json"],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["facts"]["fmiVersion"] == "3.0"
    assert data["facts"]["interfaceTypes"] == "cs,me"
    ports = {p["name"]: p for p in data["ports"]}
    assert list(ports) == [*INPUTS, *OUTPUTS]  # the independent `time` is no port
    assert {n: ports[n]["causality"] for n in INPUTS} == dict.fromkeys(INPUTS, "input")
    assert {n: ports[n]["causality"] for n in OUTPUTS} == dict.fromkeys(OUTPUTS, "output")
    assert all(p["dtype"] == "float64" and p["shape"] == [] for p in ports.values())
    assert {n: p["unit"] for n, p in ports.items()} == {
        "qw": None, "qx": None, "qy": None, "qz": None,
        "x": "m", "y": "m", "posX": "m", "posY": "m", "theta": "rad",
    }  # fmt: skip
    assert ports["posX"]["depends_on"] == ["x"]
    assert ports["posY"]["depends_on"] == ["y"]
    assert sorted(ports["theta"]["depends_on"]) == ["qw", "qx", "qy", "qz"]


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_fmi3_outputs_equal_the_fmi2_build_for_the_same_inputs(fmi_type: str) -> None:
    rows = special_inputs()
    fmi2 = _simulate("ReadOdometry.fmu", fmi_type, rows)
    fmi3 = _simulate("ReadOdometry3.fmu", fmi_type, rows)
    np.testing.assert_array_equal(fmi3, fmi2)
    theta = fmi3[:, 2]
    assert np.abs(theta[:3]).min() > 3.14  # the corpus really visits the +-pi seam
    assert theta[-1] == 0.0  # and the zero quaternion reached the output


def test_fmi3_theta_is_the_yaw_near_pi_and_for_non_unit_quaternions(slave) -> None:
    fmu, vr = slave
    rows = special_inputs()[:-1]  # numpy_yaw is undefined for the zero quaternion
    inputs = [vr[n] for n in INPUTS]
    got = np.empty((len(rows), 3))
    for k, row in enumerate(rows):
        fmu.setFloat64(inputs, row.tolist())
        got[k] = fmu.getFloat64([vr[n] for n in OUTPUTS])
    np.testing.assert_array_equal(got[:, :2], rows[:, 4:])
    error = angle_error(got[:, 2], numpy_yaw(rows[:, :4]))
    assert error.max() <= 1e-12, f"worst row {rows[error.argmax()]}"


def test_fmi3_state_round_trip_restores_the_inputs(slave) -> None:
    fmu, vr = slave
    fmu.setFloat64([vr["x"]], [4.0])
    state = fmu.getFMUState()
    fmu.setFloat64([vr["x"]], [-1.0])
    fmu.setFMUState(state)
    fmu.freeFMUState(state)
    assert fmu.getFloat64([vr["posX"]]) == [4.0]


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_fmi3_build_runs_in_a_system_fed_by_the_fmi2_build(tmp_path: Path, interface: str) -> None:
    q = euler_to_quaternion(0.05, -0.1, np.pi - 1e-7) * 3.0  # near +pi, non-unit
    quaternion = ", ".join(f"q{c}: {float(v)!r}" for c, v in zip("wxyz", q, strict=True))
    system = tmp_path / "system.yaml"
    system.write_text(
        f"""
fmionnx: 1
name: odometry-fmi2-to-fmi3
run: {{stop: 0.5, step: 0.1}}
components:
  odo2: {{kind: fmu, path: {built_model("ReadOdometry.fmu")}, parameters: {{x: 2.5, y: -1.25}}}}
  odo3:
    kind: fmu
    path: {built_model("ReadOdometry3.fmu")}
    interface: {interface}
    parameters: {{{quaternion}}}
connections:
  - odo2.posX -> odo3.x
  - odo2.posY -> odo3.y
record: [odo3.posX, odo3.posY, odo3.theta]
""",
        encoding="utf-8",
    )
    result = fmionnx.load(system).run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    np.testing.assert_array_equal(result["odo3.posX"][1:], 2.5)
    np.testing.assert_array_equal(result["odo3.posY"][1:], -1.25)
    expected = numpy_yaw(q[None, :])[0]
    assert expected == pytest.approx(np.pi - 1e-7, abs=1e-12)
    np.testing.assert_allclose(result["odo3.theta"], expected, rtol=0, atol=1e-12)


def test_fmi3_build_stages_the_fmi2_models_equations_and_only_the_fmi3_glue(tmp_path: Path) -> None:
    build = _models_build()
    assert not (REPO / "models" / "fmus" / "ReadOdometry3" / "sources" / "model.c").exists()
    fmi2 = build.stage_fmu("ReadOdometry", tmp_path) / "sources"
    fmi3 = build.stage_fmu("ReadOdometry3", tmp_path) / "sources"
    assert (fmi3 / "model.c").read_bytes() == (fmi2 / "model.c").read_bytes()
    assert sorted(p.name for p in fmi3.iterdir()) == [
        "buildDescription.xml", "config.h", "fmi3Functions.c", "model.c", "model.h",
    ]  # fmt: skip
    assert not (fmi2 / "fmi3Functions.c").exists()
    # the cache of the FMI 3 build follows the shared model source
    assert REPO / "models" / "fmus" / "ReadOdometry" / "sources" in build._inputs("ReadOdometry3")
