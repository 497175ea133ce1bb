"""Smoke tests of the ROS 2 benchmarks: each runs in a tiny configuration and prints its table.

Behaviour only: answers are matched to the right frames, the real nodes answer, both lockstep
modes run the same steps with the same results. Latencies and rates are never asserted.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

import fmionnx
from benchmarks import ros2_lockstep, ros2_pipeline
from tests.conftest import built_model
from tests.ros2.test_run import processes_with

#: A benchmark's quick run: `make soak` runs it, `make test` does not (docs/contributing.md).
pytestmark = pytest.mark.slow


def test_each_board_position_has_its_own_steering_value_and_detected_column() -> None:
    steering = [ros2_pipeline.steering(p) for p in ros2_pipeline.POSITIONS]
    assert len(set(steering)) == len(steering)
    assert 0.0 not in steering  # w = 0 is what the tracker sends while searching
    assert max(abs(w) for w in steering) < 0.8  # never clamped by turnRate
    frame = ros2_pipeline.frame_with_board(100)
    _, columns = np.nonzero((frame[..., 0] <= 40) & (frame[..., 1] <= 55) & (frame[..., 2] >= 50))
    assert columns.size == 40 * 60  # blob size sqrt(2 * 2400) = 69: approach, never act
    assert columns.mean() == ros2_pipeline.board_column(100)


def test_an_answer_counts_for_the_latest_frame_of_its_value_and_only_once() -> None:
    published = [0.0, 1.0, 2.0, 3.0]
    positions = [10, 20, 10, 30]
    lookup = ros2_pipeline.nearest_position({10: 0.1, 20: 0.2, 30: 0.3}, 1e-6)
    received = [
        (0.5, 0.0),  # no board: ignored
        (1.5, 0.1),  # frame 0's value, frame 0 is the latest with it
        (1.6, 0.2),  # frame 1
        (1.7, 0.2),  # held value: already answered
        (2.5, 0.1),  # frame 2 (same position as frame 0, published later)
    ]
    answered = ros2_pipeline.match(published, positions, received, lookup)
    assert answered == [1.5, 1.6, 2.5, None]  # frame 3 dropped


def test_the_30_hz_variant_is_the_reference_system_on_a_finer_grid_with_the_world_external(
    tmp_path,
) -> None:
    for rate, step, period in ((30.0, 1 / 1500, 1 / 30), (10.0, 0.002, 0.1)):
        path = tmp_path / f"v{rate:g}.yaml"
        path.write_text(ros2_pipeline.variant_text(rate, 1.0), encoding="utf-8")
        system = fmionnx.load(path).compiled
        assert system.run.step == pytest.approx(step)
        assert system.component("detector").period == pytest.approx(period)
        assert system.component("world").external
        assert system.component("tracker").period == pytest.approx(0.01)


@pytest.mark.ros2
def test_pipeline_benchmark_gets_cmd_vel_answers_from_the_real_nodes_and_prints_its_table(
    capsys: pytest.CaptureFixture[str],
) -> None:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    # in this process: a domain apart from tests/ros2's (one Cyclone configuration per domain)
    domain = str(random.SystemRandom().randint(210, 229))
    args = ["--rates", "30", "--multicast-rates", "--seconds", "0.5", "--warmup", "0.5"]
    (outcome,) = ros2_pipeline.main([*args, "--domain", domain])
    assert outcome.node_exit_codes == {"odometry": 0, "detector": 0, "tracker": 0}
    assert outcome.frames == 15
    assert len(outcome.answers.published) == 15 + 15 + 15  # warm-up, measured, tail
    assert outcome.cmd_ms, "no frame was answered on /cmd_vel"
    assert len(outcome.cmd_ms) + outcome.dropped == outcome.frames
    assert all(ms > 0 for ms in outcome.cmd_ms + outcome.blob_ms)
    printed = capsys.readouterr().out
    assert "frame -> /cmd_vel received (ms)" in printed
    assert "dropped frames (no /cmd_vel answer)" in printed
    assert processes_with("fmionnx-pipeline-") == []


@pytest.mark.ros2
def test_lockstep_benchmark_runs_both_modes_to_identical_results_and_prints_the_ratio(
    capsys: pytest.CaptureFixture[str],
) -> None:
    built_model("ReadOdometry.fmu")
    samples = ros2_lockstep.main(["--stop", "0.1", "--repeat", "1"])
    assert set(samples) == {ros2_lockstep.INPROCESS, ros2_lockstep.LOCKSTEP}
    assert [s.steps for s in samples.values()] == [[50], [50]]
    assert ros2_lockstep.identical(samples)
    assert all(math.isfinite(s.steps_per_s) for s in samples.values())
    printed = capsys.readouterr().out
    assert "ros2 lockstep" in printed
    assert "byte-identical to in-process" in printed
    assert processes_with("fmionnx-lockstep-") == []
