"""Smoke test of benchmarks/detector.py: every contender runs and agrees; nothing timed is asserted."""

from __future__ import annotations

import io

import numpy as np
from rich.console import Console

from benchmarks import detector
from tests.conftest import built_model


def test_fast_numpy_measure_equals_the_reference_numpy_measure() -> None:
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    # every box edge value in every channel, so an off-by-one bound would show
    edges = np.array([0, 39, 40, 41, 49, 50, 51, 54, 55, 56, 99, 100, 101, 255], np.uint8)
    image[:100, :, :] = rng.choice(edges, (100, 640, 3))
    image[200:260, 300:340] = (200, 10, 10)
    for frame in (image, np.zeros_like(image), np.full_like(image, 128)):
        fast = detector.numpy_blobs_fast(frame)
        reference = detector.md.numpy_blobs(frame)
        assert detector.same(fast, reference)
        np.testing.assert_array_equal(fast[1], reference[1])


def test_quick_run_prints_detector_and_render_tables_with_the_target() -> None:
    built_model("sign_detector.onnx")
    text = io.StringIO()
    results = detector.main(["--quick"], Console(file=text, width=200))
    rows = {r["contender"]: r for r in results["detector"]}
    assert set(rows) == {
        detector.RUNNER,
        detector.TWO_THREADS,
        detector.DEFAULT_LEVEL,
        *detector.NUMPYS,
    }
    assert all(r["correct"] for r in rows.values())
    assert min(rows[name]["vs_numpy"] for name in detector.NUMPYS) == 1.0
    assert [r["scene"] for r in results["render"]] == ["before (issue 14)", "committed"]
    assert "settings" not in results  # --quick leaves the per-setting table out
    (target,) = results["targets"]
    assert target["value"] == rows[detector.RUNNER]["vs_numpy"]
    printed = text.getvalue()
    assert "Detector per 640x480 frame" in printed
    assert "Render per frame" in printed
    assert "Targets" in printed
