"""The lockstep sample count equals the number of values the in-process master has seen."""

from __future__ import annotations

import pytest

from fmionnx.backends.ros2.schedule import Reader, TopicSchedule


def _brute_count(schedule: TopicSchedule, n: int, position: int) -> int:
    count = 1 if schedule.published_at_init() else 0
    for m in range(0, n + 1, schedule.period):
        if (m < n or schedule.position < position) and schedule.published_at(m):
            count += 1
    return count


@pytest.mark.parametrize(
    ("period", "position", "reader"),
    [(1, 0, Reader(5, 1)), (5, 2, Reader(1, 0)), (3, 1, Reader(2, 1)), (50, 0, Reader(50, 2))],
)
def test_count_before_matches_a_direct_count_for_plain_topics(period, position, reader) -> None:
    schedule = TopicSchedule("/t", period, position, lazy=False, readers=(reader,))
    for n in range(0, 300, reader.period):
        assert schedule.count_before(n, reader.position) == _brute_count(
            schedule, n, reader.position
        )
        assert schedule.count_before(n, reader.position) == 1 + (n + period - 1) // period + (
            1 if n % period == 0 and position < reader.position else 0
        )


def test_lazy_image_is_published_only_after_steps_a_reader_sees() -> None:
    # the reference robot: world (every step, first) renders for the detector (every 50 steps)
    camera = TopicSchedule("/camera", 1, 0, lazy=True, readers=(Reader(50, 2),))
    published = [m for m in range(200) if camera.published_at(m)]
    assert published == [0, 50, 100, 150]
    assert not camera.published_at_init()
    assert camera.count_before(0, 2) == 1  # the frame rendered after the world's step 0
    assert camera.count_before(50, 2) == 2
    # a reader *before* the producer in the order sees the state before the producer's step
    early = TopicSchedule("/camera", 1, 3, lazy=True, readers=(Reader(50, 0),))
    assert early.published_at_init()
    assert [m for m in range(200) if early.published_at(m)] == [49, 99, 149, 199]
    assert early.count_before(0, 0) == 1
    assert early.count_before(50, 0) == 2


def test_a_lazy_image_read_by_a_model_evaluated_at_start_is_published_after_set_up() -> None:
    """An ONNX detector computes its start outputs from the initial frame (issue #34): the
    camera publishes it after set-up, and the step-0 frame becomes the second sample."""
    camera = TopicSchedule("/camera", 1, 0, lazy=True, readers=(Reader(50, 2, at_start=True),))
    assert camera.published_at_init()
    assert [m for m in range(200) if camera.published_at(m)] == [0, 50, 100, 150]
    assert camera.count_before(0, 2) == 2  # the initial frame, then the one after step 0
    assert camera.count_before(50, 2) == 3


def test_the_reference_detector_reads_the_camera_at_start() -> None:
    from fmionnx import api
    from fmionnx.backends.ros2.loading import plan_for
    from fmionnx.backends.ros2.schedule import topic_schedules
    from tests.conftest import REPO

    compiled = api.load(REPO / "systems" / "sign_follower.yaml").compiled
    plan = plan_for(compiled)
    schedules = topic_schedules(compiled, plan)
    assert schedules["/camera/image_raw"].published_at_init()
