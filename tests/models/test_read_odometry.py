"""ReadOdometry FMU against a numpy reference: yaw from the rotation matrix of q/|q|."""

from __future__ import annotations

import shutil
from collections.abc import Iterator

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.validation import validate_fmu

from tests.conftest import built_model

N_RANDOM = 4000


def numpy_yaw(q: np.ndarray) -> np.ndarray:
    """Yaw of quaternions (n, 4) in (w, x, y, z) order: atan2(R[1,0], R[0,0]) of q/|q|."""
    u = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = u.T
    r10 = 2.0 * (x * y + w * z)
    r00 = 1.0 - 2.0 * (y * y + z * z)
    return np.arctan2(r10, r00)


def angle_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| on the circle, so that pi and -pi agree."""
    return np.abs(np.angle(np.exp(1j * (a - b))))


def quaternion_corpus() -> np.ndarray:
    """Random rotations (unit and scaled by 1e-3..1e3), yaw near +-pi, and pure yaws."""
    rng = np.random.default_rng(20240501)
    unit = rng.normal(size=(N_RANDOM, 4))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    scaled = unit * 10.0 ** rng.uniform(-3, 3, size=(N_RANDOM, 1))
    yaw = np.concatenate([np.pi - np.logspace(-12, -1, 200), -np.pi + np.logspace(-12, -1, 200)])
    tilt = rng.uniform(-0.3, 0.3, size=(len(yaw), 2))  # small roll and pitch
    near_pi = np.array([euler_to_quaternion(r, p, t) for (r, p), t in zip(tilt, yaw, strict=True)])
    grid = np.linspace(-np.pi, np.pi, 721)
    pure = np.stack([np.cos(grid / 2), 0 * grid, 0 * grid, np.sin(grid / 2)], axis=1)
    return np.concatenate([unit, scaled, near_pi, near_pi * 7.5, pure])


def euler_to_quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(w, x, y, z) of the rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


@pytest.fixture(scope="module")
def odometry() -> Iterator[tuple[FMU2Slave, dict[str, int]]]:
    path = built_model("ReadOdometry.fmu")
    description = read_model_description(str(path))
    unzipped = extract(str(path))
    slave = FMU2Slave(
        guid=description.guid, unzipDirectory=unzipped, modelIdentifier="ReadOdometry"
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    yield slave, {v.name: v.valueReference for v in description.modelVariables}
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(unzipped, ignore_errors=True)


def test_theta_matches_numpy_yaw_for_unit_scaled_and_near_pi_quaternions(odometry):
    slave, vr = odometry
    quats = quaternion_corpus()
    inputs = [vr[n] for n in ("qw", "qx", "qy", "qz")]
    theta = np.empty(len(quats))
    for k, q in enumerate(quats):
        slave.setReal(inputs, q.tolist())
        theta[k] = slave.getReal([vr["theta"]])[0]
    error = angle_error(theta, numpy_yaw(quats))
    assert error.max() <= 1e-12, f"worst quaternion {quats[error.argmax()]}"
    assert np.all((theta > -np.pi - 1e-15) & (theta <= np.pi))


def test_theta_is_invariant_to_the_quaternion_scale(odometry):
    slave, vr = odometry
    inputs = [vr[n] for n in ("qw", "qx", "qy", "qz")]
    q = np.array([0.3, -0.2, 0.1, 0.9])
    slave.setReal(inputs, q.tolist())
    reference = slave.getReal([vr["theta"]])[0]
    for scale in (1e-6, 0.5, 3.0, 1e6):
        slave.setReal(inputs, (q * scale).tolist())
        assert slave.getReal([vr["theta"]])[0] == pytest.approx(reference, abs=1e-15)


def test_position_passes_through_and_is_direct_feedthrough(odometry):
    slave, vr = odometry
    slave.setReal([vr["x"], vr["y"]], [1.25, -7.5])
    assert slave.getReal([vr["posX"], vr["posY"]]) == [1.25, -7.5]


def test_model_exchange_interface_gives_the_same_pose():
    path = built_model("ReadOdometry.fmu")
    description = read_model_description(str(path))
    unzipped = extract(str(path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    model = FMU2Model(
        guid=description.guid, unzipDirectory=unzipped, modelIdentifier="ReadOdometry"
    )
    try:
        model.instantiate()
        model.setupExperiment(startTime=0.0)
        model.enterInitializationMode()
        model.exitInitializationMode()
        model.enterContinuousTimeMode()
        q = euler_to_quaternion(0.1, -0.2, 2.5)
        model.setReal([vr[n] for n in ("qw", "qx", "qy", "qz", "x", "y")], [*q, 3.0, 4.0])
        pos_x, pos_y, theta = model.getReal([vr["posX"], vr["posY"], vr["theta"]])
        assert (pos_x, pos_y) == (3.0, 4.0)
        assert theta == pytest.approx(2.5, abs=1e-12)
        model.terminate()
        model.freeInstance()
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)


@pytest.mark.parametrize("name", ["ReadOdometry.fmu", "SignTrackingLogic.fmu"])
def test_fmu_passes_fmpy_validation(name):
    assert validate_fmu(str(built_model(name))) == []


def test_model_description_declares_units_and_feedthrough():
    description = read_model_description(str(built_model("ReadOdometry.fmu")))
    units = {v.name: v.unit for v in description.modelVariables}
    assert units["posX"] == units["posY"] == units["x"] == "m"
    assert units["theta"] == "rad"
    deps = {o.variable.name: sorted(d.name for d in o.dependencies) for o in description.outputs}
    assert deps == {"posX": ["x"], "posY": ["y"], "theta": ["qw", "qx", "qy", "qz"]}
    assert description.coSimulation is not None
    assert description.modelExchange is not None
