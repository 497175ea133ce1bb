"""The reference scenario end to end: the robot reaches B, having taken every turn."""

from __future__ import annotations

import hashlib
import itertools

import numpy as np
import pytest

import fmionnx
from fmionnx.compile.expected_path import read_expected_path
from fmionnx.results.csvfile import write_csv
from fmionnx.runtime.checks import evaluate_checks
from fmionnx.runtime.result import RunStatus
from tests.conftest import REPO, built_model

SYSTEM = REPO / "systems" / "sign_follower.yaml"
GOAL_B = np.array([6.0, 3.0])


def distance_to_polyline(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Shortest distance of each point to the piecewise-linear path."""
    best = np.full(len(points), np.inf)
    for a, b in itertools.pairwise(path):
        ab = b - a
        s = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + s[:, None] * ab), axis=1))
    return best


@pytest.fixture(scope="module")
def run_result():
    built_model("ReadOdometry.fmu")  # raises with a `make models` hint when missing
    return fmionnx.load(SYSTEM).run(isolate="none")


def test_robot_reaches_b_within_half_a_metre_and_stops(run_result) -> None:
    assert run_result.status is RunStatus.COMPLETED
    end = np.array([run_result["odometry.posX"][-1], run_result["odometry.posY"][-1]])
    assert np.linalg.norm(end - GOAL_B) < 0.5
    assert run_result["tracker.v"][-1] == 0.0
    assert run_result["tracker.w"][-1] == 0.0


def test_robot_path_stays_within_30_cm_of_the_expected_path(run_result) -> None:
    path = np.array(read_expected_path(REPO / "models" / "world" / "sign_course.path.csv"))
    points = np.column_stack([run_result["odometry.posX"], run_result["odometry.posY"]])
    assert distance_to_polyline(points, path).max() < 0.3
    # every corner of the expected path is passed (every turn was taken)
    for corner in path[1:-1]:
        assert np.linalg.norm(points - corner, axis=1).min() < 0.3


#: sha256 of the reference scenario's results.csv, written before the layers were restructured
#: (issue #12): a refactoring must not change one byte of the results. A deliberate change of
#: the models or of the CSV format updates this value in the same commit, saying why.
#: Last change: numbers as their shortest round-tripping decimal instead of 17 digits (issue
#: #16); the old and the new file parse to bit-identical float64 tables.
#: Last change: the sign course renders only what the camera needs (issue #14: no anti-aliasing,
#: no skybox, a plain floor, the headlight only), so the camera's frames and everything after
#: them differ; the checks still hold (end 0.0224 m from B, largest deviation 0.0238 m).
#: Last change (issues #33 and #34 merged): default recording is every output (29 signals, was
#: 18: world.A.pos, world.B.pos, world.base.pos, tracker.stopRobot, tracker.state); the
#: detector's tensor elements are named with one index per dimension (`"detector.blobX[0,2]"`,
#: quoted for its comma; was `detector.blobX[2]`); an ONNX component's outputs at the start
#: time come from its start inputs, so the detector's columns from 0 to 0.098 s (rows 1-50)
#: hold what it sees in the first frame instead of its output for a black frame. Compared
#: column by column with the file before the merge: nothing else changed.
REFERENCE_RESULTS_SHA256 = "b028fde126b0d4127ee3506aa804dc08921477825c4df1c2f0f3f3d66d674a70"


def test_reference_results_csv_is_byte_identical_to_the_recorded_hash(run_result, tmp_path) -> None:
    written = write_csv(run_result, tmp_path / "results.csv")
    assert hashlib.sha256(written.read_bytes()).hexdigest() == REFERENCE_RESULTS_SHA256


def test_the_reference_system_states_its_own_checks_and_they_hold(run_result) -> None:
    outcomes = evaluate_checks(fmionnx.load(SYSTEM).compiled.checks, run_result)
    assert [o.name for o in outcomes] == ["reaches B", "stops", "stays on the path"]
    assert all(o.passed for o in outcomes), outcomes
    measured = {o.name: o.value for o in outcomes}
    end = np.array([run_result["odometry.posX"][-1], run_result["odometry.posY"][-1]])
    assert measured["reaches B"] == pytest.approx(np.linalg.norm(end - GOAL_B), abs=1e-9)
    path = np.array(read_expected_path(REPO / "models" / "world" / "sign_course.path.csv"))
    points = np.column_stack([run_result["odometry.posX"], run_result["odometry.posY"]])
    assert measured["stays on the path"] == pytest.approx(distance_to_polyline(points, path).max())


def test_the_reference_run_steps_both_fmus_natively(run_result) -> None:
    """The tracker's blobX/blobSize come from the detector's float32 outputs (issue 14): it is
    stepped by the native kernel with odometry, and results.csv keeps its hash (above)."""
    details = run_result.details
    assert (details["native"], details["native_components"]) == (True, 2)
    assert "native_python.tracker" not in details
    assert "native_python.odometry" not in details
    assert sorted(k for k in details if k.startswith("native_python.")) == [
        "native_python.detector",
        "native_python.world",
    ]
