"""SignTrackingLogic3, the FMI 3.0 build of SignTrackingLogic: true arrays, same commands, runs.

The FMI 3 build declares ``blobSize`` and ``blobX`` as Float64 arrays of three elements (one
value reference each) over the same model.c as the FMI 2 build, whose indexed scalars
``blobSize[1]`` .. ``blobX[3]`` are the same reals.
"""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.compile.expected_path import read_expected_path
from fmionnx.runtime.result import RunStatus
from tests.backends.test_sign_follower import GOAL_B, distance_to_polyline
from tests.conftest import REPO, built_model
from tests.models.test_read_odometry_fmi3 import _models_build

SEARCH, APPROACH, TURN_LEFT, TURN_RIGHT, STOP = range(5)
H = 0.01
CENTRE = 319.5
NONE = ((0.0, 0.0, 0.0), (-1.0, -1.0, -1.0))
Row = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


def script() -> list[Row]:
    """(blobSize, blobX, pose) per step: search with heading hold, approach a blue sign off
    centre, turn left across the heading, search again until rearmed, approach and turn right
    on green, then approach red and stop (and stay stopped with a sign in view)."""
    rows: list[Row] = []

    def add(sizes: tuple[float, float, float], xs: tuple[float, float, float], pose: Any) -> None:
        rows.append((sizes, xs, pose))

    add(*NONE, (0.0, 0.0, 0.0))
    add(*NONE, (0.1, 0.01, 0.05))  # drifted left: steer back
    add((0.0, 0.0, 100.0), (-1.0, -1.0, CENTRE + 160.0), (0.2, 0.0, 0.0))  # approach blue
    add((0.0, 0.0, 200.0), (-1.0, -1.0, CENTRE - 100.0), (0.3, 0.0, 0.0))
    add((0.0, 0.0, 320.0), (-1.0, -1.0, CENTRE), (0.4, 0.0, 0.0))  # turn left
    for theta in (0.3, 1.0, 1.5, math.pi / 2 - 0.005):
        add(*NONE, (0.4, 0.0, theta))
    add((0.0, 120.0, 0.0), (-1.0, CENTRE, -1.0), (0.4, 0.3, math.pi / 2))  # not yet rearmed
    add((0.0, 120.0, 0.0), (-1.0, CENTRE + 40.0, -1.0), (0.4, 0.7, math.pi / 2))  # approach
    add((0.0, 310.0, 0.0), (-1.0, CENTRE, -1.0), (0.4, 0.8, math.pi / 2))  # turn right
    for theta in (1.2, 0.3, -0.02, 0.004):
        add(*NONE, (0.4, 0.8, theta))
    add((90.0, 0.0, 0.0), (CENTRE - 300.0, -1.0, -1.0), (1.5, 0.8, 0.0))  # approach red
    add((300.0, 0.0, 0.0), (CENTRE, -1.0, -1.0), (1.6, 0.8, 0.0))  # stop
    add((0.0, 0.0, 500.0), (-1.0, -1.0, CENTRE), (1.6, 0.8, 0.0))  # stays stopped
    return rows


class Slave:
    """One build in co-simulation; ``step`` sets the inputs, advances ``H``, reads the outputs
    (v, w, stopRobot, state). FMI 2 sets the six indexed scalars, FMI 3 the two arrays."""

    def __init__(self, name: str) -> None:
        path = built_model(f"{name}.fmu")
        self.description = read_model_description(str(path))
        self.unzipped = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.fmi3 = self.description.fmiVersion.startswith("3")
        self.time = 0.0
        if self.fmi3:
            fmu3 = FMU3Slave(
                guid=self.description.guid, unzipDirectory=self.unzipped, modelIdentifier=name
            )
            fmu3.instantiate()
            fmu3.enterInitializationMode(startTime=0.0)
            fmu3.exitInitializationMode()
            self.fmu: Any = fmu3
        else:
            fmu2 = FMU2Slave(
                guid=self.description.guid, unzipDirectory=self.unzipped, modelIdentifier=name
            )
            fmu2.instantiate()
            fmu2.setupExperiment(startTime=0.0)
            fmu2.enterInitializationMode()
            fmu2.exitInitializationMode()
            self.fmu = fmu2

    def step(self, row: Row) -> tuple[float, float, bool, int]:
        sizes, xs, pose = row
        pose_vrs = [self.vr[n] for n in ("posX", "posY", "theta")]
        if self.fmi3:
            self.fmu.setFloat64(
                [self.vr["blobSize"], self.vr["blobX"], *pose_vrs], [*sizes, *xs, *pose]
            )
        else:
            vrs = [self.vr[f"{b}[{i}]"] for b in ("blobSize", "blobX") for i in (1, 2, 3)]
            self.fmu.setReal([*vrs, *pose_vrs], [*sizes, *xs, *pose])
        self.fmu.doStep(self.time, H)
        self.time += H
        if self.fmi3:
            v, w = self.fmu.getFloat64([self.vr["v"], self.vr["w"]])
            stop = self.fmu.getBoolean([self.vr["stopRobot"]])[0]
            state = self.fmu.getInt32([self.vr["state"]])[0]
        else:
            v, w = self.fmu.getReal([self.vr["v"], self.vr["w"]])
            stop = self.fmu.getBoolean([self.vr["stopRobot"]])[0]
            state = self.fmu.getInteger([self.vr["state"]])[0]
        return v, w, bool(stop), int(state)

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


@pytest.fixture
def fmi3() -> Iterator[Slave]:
    slave = Slave("SignTrackingLogic3")
    yield slave
    slave.close()


def test_fmi3_build_passes_fmpy_validation() -> None:
    assert validate_fmu(str(built_model("SignTrackingLogic3.fmu"))) == []


def test_inspect_shows_blob_inputs_as_float64_arrays_of_three(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(
        app,
        ["inspect", str(built_model("SignTrackingLogic3.fmu")), "--format", "json"],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["facts"]["fmiVersion"] == "3.0"
    ports = {p["name"]: p for p in data["ports"]}
    for name, start in (("blobSize", [0.0] * 3), ("blobX", [-1.0] * 3)):
        assert (ports[name]["dtype"], ports[name]["shape"]) == ("float64", [3])
        assert ports[name]["causality"] == "input"
        assert ports[name]["start"] == start
    assert {n: (ports[n]["dtype"], ports[n]["unit"]) for n in ("v", "w", "stopRobot", "state")} == {
        "v": ("float64", "m/s"),
        "w": ("float64", "rad/s"),
        "stopRobot": ("bool", None),
        "state": ("int32", None),
    }
    assert all(ports[n]["depends_on"] == [] for n in ("v", "w", "stopRobot", "state"))
    assert (ports["imageWidth"]["dtype"], ports["imageWidth"]["start"]) == ("int32", [640])
    assert (ports["snapHeading"]["dtype"], ports["snapHeading"]["start"]) == ("bool", [True])
    assert (ports["turnRate"]["unit"], ports["turnRate"]["start"]) == ("rad/s", [0.8])


def test_fmi3_commands_equal_the_fmi2_build_through_every_state() -> None:
    rows = script()
    builds = [Slave("SignTrackingLogic"), Slave("SignTrackingLogic3")]
    try:
        fmi2, fmi3 = [[b.step(row) for row in rows] for b in builds]
    finally:
        for build in builds:
            build.close()
    assert fmi3 == fmi2
    states = [out[3] for out in fmi3]
    # the script really drives search, approach, both turns and the stop
    assert states[:5] == [SEARCH, SEARCH, APPROACH, APPROACH, TURN_LEFT]
    assert {TURN_RIGHT, STOP} <= set(states)
    assert fmi3[-1] == (0.0, 0.0, True, STOP)
    assert fmi3[3][1] != 0.0  # the blue sign left of centre steers: blobX reached the model


def test_an_array_takes_all_its_elements_in_one_call(fmi3: Slave) -> None:
    fmi3.fmu.setFloat64([fmi3.vr["blobX"]], [10.0, 20.0, 30.0])
    assert fmi3.fmu.getFloat64([fmi3.vr["blobX"], fmi3.vr["posX"]], nValues=4) == [
        10.0, 20.0, 30.0, 0.0,
    ]  # fmt: skip
    assert fmi3.fmu.getFloat64([fmi3.vr["blobSize"]], nValues=3) == [0.0, 0.0, 0.0]


@pytest.mark.parametrize(
    ("vrs", "n_values"),
    [([3], 1), ([3], 4), ([4], 1), ([0, 6], 2)],
    ids=["too-few-values", "too-many-values", "element-of-an-array", "array-counted-as-one"],
)
def test_a_wrong_element_count_or_an_array_element_is_refused(
    fmi3: Slave, vrs: list[int], n_values: int
) -> None:
    with pytest.raises(FMICallException):
        fmi3.fmu.getFloat64(vrs, nValues=n_values)
    with pytest.raises(FMICallException):
        fmi3.fmu.setFloat64(vrs, [7.0] * n_values)
    assert fmi3.fmu.getFloat64([3, 0, 6], nValues=7) == [-1.0] * 3 + [0.0] * 4  # unchanged


def _system(tmp_path: Path, tracker: str, stop: float) -> Path:
    """systems/sign_follower.yaml in ``tmp_path`` with absolute paths, the tracker FMU
    ``tracker`` and the stop time ``stop``; its blob connections stay whole-array ones."""
    text = (REPO / "systems" / "sign_follower.yaml").read_text(encoding="utf-8")
    assert "detector.blobX -> tracker.blobX" in text
    assert "stop: 32," in text
    text = text.replace("path: ../build/models/SignTrackingLogic.fmu", f"path: {tracker}")
    text = text.replace("path: ../", f"path: {REPO}/").replace("stop: 32,", f"stop: {stop},")
    path = tmp_path / f"{Path(tracker).stem}-{stop}.yaml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def fmi3_run(tmp_path_factory: pytest.TempPathFactory) -> Any:
    system = _system(
        tmp_path_factory.mktemp("fmi3"), str(built_model("SignTrackingLogic3.fmu")), 32
    )
    return fmionnx.load(system).run(isolate="none")


def test_sign_follower_with_the_fmi3_tracker_reaches_b(fmi3_run: Any) -> None:
    assert fmi3_run.status is RunStatus.COMPLETED
    end = np.array([fmi3_run["odometry.posX"][-1], fmi3_run["odometry.posY"][-1]])
    assert np.linalg.norm(end - GOAL_B) < 0.5
    assert fmi3_run["tracker.v"][-1] == 0.0
    path = np.array(read_expected_path(REPO / "models" / "world" / "sign_course.path.csv"))
    points = np.column_stack([fmi3_run["odometry.posX"], fmi3_run["odometry.posY"]])
    assert distance_to_polyline(points, path).max() < 0.3
    for corner in path[1:-1]:
        assert np.linalg.norm(points - corner, axis=1).min() < 0.3


def test_sign_follower_commands_are_those_of_the_fmi2_tracker(
    fmi3_run: Any, tmp_path: Path
) -> None:
    stop = 8.0  # past the first sign: the blob arrays steer the robot by then
    system = _system(tmp_path, str(built_model("SignTrackingLogic.fmu")), stop)
    fmi2_run = fmionnx.load(system).run(isolate="none")
    assert fmi2_run.status is RunStatus.COMPLETED
    n = len(fmi2_run.time)
    np.testing.assert_array_equal(fmi3_run.time[:n], fmi2_run.time)
    for signal in ("tracker.v", "tracker.w"):
        np.testing.assert_array_equal(fmi3_run[signal][:n], fmi2_run[signal], err_msg=signal)
    assert np.any(fmi2_run["tracker.v"] == 0.4)  # an approach happened in the compared span


def test_fmi3_build_stages_the_fmi2_equations_and_its_array_table(tmp_path: Path) -> None:
    build = _models_build()
    fmi2 = build.stage_fmu("SignTrackingLogic", tmp_path) / "sources"
    fmi3 = build.stage_fmu("SignTrackingLogic3", tmp_path) / "sources"
    assert (fmi3 / "model.c").read_bytes() == (fmi2 / "model.c").read_bytes()
    assert sorted(p.name for p in fmi3.iterdir()) == [
        "buildDescription.xml", "config.h", "fmi3Arrays.h", "fmi3Functions.c", "model.c", "model.h",
    ]  # fmt: skip
    assert REPO / "models" / "fmus" / "SignTrackingLogic" / "sources" in build._inputs(
        "SignTrackingLogic3"
    )
