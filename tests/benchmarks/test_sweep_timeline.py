"""benchmarks/sweep_scaling.timeline: the time outside a study's cases, split by when."""

from __future__ import annotations

import pytest

from benchmarks.sweep_scaling import timeline


def test_before_idle_and_after_add_up_to_the_time_outside_the_cases() -> None:
    # Two workers from t=100 to t=120: the first case starts at 103, the last ends at 117.
    spans = [(103.0, 4.0), (107.0, 5.0), (103.5, 6.0), (110.0, 7.0)]
    before, idle, after = timeline(spans, 2, 100.0, 120.0)
    assert before == pytest.approx(3.0)
    assert after == pytest.approx(3.0)
    # each worker could have been busy 14 s (103..117); the cases took 22 s of the 28
    assert idle == pytest.approx((2 * 14.0 - 22.0) / 2)
    busy = sum(wall for _, wall in spans) / (2 * 20.0)
    assert (2 * before + 2 * idle + 2 * after) / (2 * 20.0) == pytest.approx(1 - busy)
