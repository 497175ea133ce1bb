"""``benchmarks/ros2_zenoh.py --quick``: both wires measured, the camera run counted, nothing left."""

from __future__ import annotations

import io
import random

import pytest
from rich.console import Console

from benchmarks import ros2_zenoh
from tests.ros2.test_run import processes_with

pytestmark = [
    pytest.mark.ros2,
    pytest.mark.slow,
]  # slow: a benchmark's quick run; `make soak` runs it


def test_quick_zenoh_benchmark_measures_both_wires_and_the_30_hz_camera(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # in this process: a domain apart from tests/ros2's (one Cyclone configuration per domain)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randint(210, 229)))
    monkeypatch.setenv("ROS_LOCALHOST_ONLY", "1")
    text = io.StringIO()
    results = ros2_zenoh.main(["--quick", "--seconds", "1"], Console(file=text, width=200))
    for wire in ("zenoh", "dds"):
        p50, p99 = results[wire]["image"]
        assert 0 < p50 <= p99
        assert results[wire]["images_per_s"] > 0
    sent, back = results["camera"]
    assert sent >= 29
    assert back <= sent
    printed = text.getvalue()
    assert "640x480 rgb8 Image hop (ms)" in printed
    assert "30 Hz camera over Zenoh for 1 s" in printed
    assert processes_with("ros2_zenoh.py") == []
    assert processes_with("ros2_wire.py --echo") == []
