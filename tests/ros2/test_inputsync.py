"""Free-run input matching by stamp (:mod:`fmionnx.backends.ros2.inputsync`), no processes.

The expected stamps are checked against the lockstep rule itself (``count_before``); the
bookkeeping against samples arriving in order, reordered, too late, from the future, and
without any usable stamp.
"""

from __future__ import annotations

import struct

import numpy as np
import pytest

from fmionnx.backends.ros2.codec import WHOLE, PortField, TopicCodec
from fmionnx.backends.ros2.inputsync import (
    MAX_PENDING,
    Match,
    StampedInput,
    StepScale,
    expected_stamp,
    header_stamp_ns,
    starts_with_header,
)
from fmionnx.backends.ros2.loading import plan_for
from fmionnx.backends.ros2.schedule import Reader, TopicSchedule, topic_schedules
from fmionnx.compile.ros2.messages import RosDistro
from tests.ros2.conftest import make_system

SCALE = StepScale(0.0, 0.002)
NS = 2_000_000  # one base step


def _stamped(match: Match = Match.SOURCE) -> StampedInput:
    return StampedInput(match, SCALE)


def _offer(sync: StampedInput, *stamps: int) -> None:
    for stamp in stamps:
        sync.offer(f"s{stamp}".encode(), stamp * NS)


# -- stamps ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("msgtype", "expected"),
    [
        ("sensor_msgs/msg/Image", True),
        ("nav_msgs/msg/Odometry", True),
        ("geometry_msgs/msg/Twist", False),
        ("std_msgs/msg/Float64MultiArray", False),
        ("geometry_msgs/msg/Pose2D", False),
        ("std_msgs/msg/Header", False),  # its first member is the stamp itself
    ],
)
def test_which_types_start_with_a_header(msgtype: str, expected: bool) -> None:
    assert starts_with_header(msgtype, RosDistro.HUMBLE) is expected


def test_the_header_stamp_is_read_from_the_cdr_bytes_without_deserialising() -> None:
    codec = TopicCodec(
        "sensor_msgs/msg/Image",
        (PortField("front", (WHOLE,), (4, 6, 3), "uint8"),),
        RosDistro.HUMBLE,
        frame_id="camera",
    )
    data = codec.encode({"front": np.zeros((4, 6, 3), np.uint8)}, 12.346)
    assert header_stamp_ns(data) == 12_346_000_000
    assert SCALE.index(header_stamp_ns(data) or 0) == 6173
    big_endian = b"\x00\x00\x00\x00" + struct.pack(">iI", 3, 500_000_000) + b"\x00" * 8
    assert header_stamp_ns(big_endian) == 3_500_000_000
    assert header_stamp_ns(b"\x00\x01\x00\x00\x01") is None


def test_expected_stamps_name_the_sample_a_lockstep_run_counts() -> None:
    """For every topic and reader of the reference system, over 300 base steps, the expected
    stamp is the stamp of sample number ``count_before`` in the producer's publication order."""
    system = make_system()
    plan = plan_for(system, RosDistro.HUMBLE)
    position = {name: i for i, name in enumerate(system.order)}
    checked = 0
    for name, schedule in topic_schedules(system, plan).items():
        published = [0] if schedule.published_at_init() else []
        published += [
            m + schedule.period for m in range(0, 400, schedule.period) if schedule.published_at(m)
        ]
        for sub in {s.component for s in plan.subscriptions if s.topic == name}:
            counter = topic_schedules(system, plan)[name]
            reader = system.component(sub)
            for n in range(0, 300, reader.period_steps):
                count = counter.count_before(n, position[sub])
                want = published[count - 1] if count else None
                assert expected_stamp(schedule, n, position[sub]) == want, (name, sub, n)
                checked += 1
    assert checked > 300


def test_expected_stamps_of_the_reference_loop() -> None:
    system = make_system()
    schedules = topic_schedules(system, plan_for(system, RosDistro.HUMBLE))
    camera = schedules["/world/front"]
    # the detector (after the world in the order) reads the frame rendered after step n
    assert [expected_stamp(camera, n, 2) for n in (0, 1, 2)] == [1, 2, 3]
    # the world reads a 5-step tracker's command across the cut loop edge: the last one the
    # tracker published before step n, stamped with the end of the tracker's step
    cmd = TopicSchedule("/cmd_vel", 5, 3, False, (Reader(1, 0),))
    assert [expected_stamp(cmd, n, 0) for n in range(8)] == [0, 5, 5, 5, 5, 5, 10, 10]
    # a 5-step reader after a 1-step producer reads its step-n output
    odom = schedules["/odom"]
    assert [expected_stamp(odom, n, 1) for n in (0, 5, 10)] == [1, 6, 11]
    lazy = TopicSchedule("/image", 1, 3, True, (), every=10)
    assert expected_stamp(lazy, 0, 1) is None  # a lazy image: nothing after set-up
    assert expected_stamp(lazy, 25, 1) == 21  # published after every 10th step only


# -- matching ----------------------------------------------------------------------------------


def test_samples_in_order_are_each_used_at_their_step() -> None:
    sync = _stamped()
    _offer(sync, 0, 5)
    assert sync.ready(0)
    assert sync.use(0) == b"s0"
    assert sync.use(0) is None  # held: nothing to load again
    assert not sync.ready(10)
    _offer(sync, 10)
    assert sync.use(5) == b"s5"
    assert sync.use(10) == b"s10"
    counts = sync.finish()
    assert (counts.received, counts.matched, counts.stale, counts.dropped) == (3, 3, 0, 0)


def test_a_reordered_sample_is_waited_for_and_the_newer_kept_for_its_step() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    _offer(sync, 10)  # overtook the one of stamp 5: a newer one means 5 is lost
    assert sync.ready(5)
    _offer(sync, 5)
    assert sync.use(5) == b"s5"
    assert sync.pending.keys() == {10}
    assert sync.use(10) == b"s10"
    assert sync.finish().as_json() == {
        "match": "source timestamp", "received": 3, "matched": 3, "stale": 0, "late": 0,
        "dropped": 0,
    }  # fmt: skip


def test_a_sample_later_than_the_wait_makes_a_stale_step_then_is_dropped() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    assert not sync.ready(5)
    assert sync.use(5) is None  # the wait ran out: nothing newer than the values held
    assert sync.ready(5)  # a later step expecting it does not wait again
    _offer(sync, 5, 10)
    assert sync.use(10) == b"s10"  # the late 5 is skipped: never used
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (2, 1, 0, 1)
    _offer(sync, 5)  # older than the sample in use: ignored
    assert not sync.pending


def test_a_stale_step_uses_the_newest_older_sample_and_a_late_one_is_used_when_still_due() -> None:
    sync = _stamped()
    _offer(sync, 0, 5)
    assert sync.use(10) == b"s5"  # stale: the newest sample older than 10
    assert sync.pending == {}
    _offer(sync, 10)
    assert sync.use(10) == b"s10"  # the next step expects the same one: used late
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (1, 1, 1, 0)


def test_after_a_stale_step_a_silent_topic_is_not_waited_for_until_a_sample_arrives() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    assert not sync.ready(5)
    sync.use(5)  # stale: the producer stopped
    assert sync.ready(10)  # no wait per step for a producer that does not publish
    assert sync.use(10) is None
    _offer(sync, 5)  # it lives again: the next step waits for its sample
    assert not sync.ready(15)
    assert sync.use(15) == b"s5"
    counts = sync.finish()
    # 10: its step did not wait (silent), so it is no dropped sample; 15 was waited for.
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (1, 3, 1, 1)


def test_a_dead_producer_adds_one_dropped_sample_and_no_bookkeeping_per_step() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    steps = 50_000  # far beyond any window: one expectation per step would show
    for n in range(1, steps + 1):
        assert sync.use(5 * n) is None
    assert sync.missed == {5}  # only the one stamp a step waited for
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (1, steps, 0, 1)


def test_missed_expectations_at_or_below_the_sample_in_use_are_settled_as_dropped() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    sync.use(5)  # stale: 5 missed
    _offer(sync, 7)  # a sample off the expected grid: 5 will never be used now
    assert sync.use(10) == b"s7"  # stale, waited for (7 arrived): 10 missed
    assert sync.missed == {10}  # 5 lies below the sample in use: settled
    assert sync.counts.dropped == 2
    _offer(sync, 10)
    assert sync.use(10) == b"s10"  # late
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (2, 2, 1, 1)


def test_missed_expectations_are_bounded_and_the_evicted_count_as_dropped() -> None:
    sync = _stamped()
    _offer(sync, 0)
    sync.use(0)
    steps = 3 * MAX_PENDING
    for n in range(1, steps + 1):
        _offer(sync, 0)  # a stuck producer repeating an old stamp: alive, never useful
        assert sync.use(n) is None
    assert len(sync.missed) == MAX_PENDING
    assert min(sync.missed) == steps - MAX_PENDING + 1  # the newest expectations are kept
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.late, counts.dropped) == (1, steps, 0, steps)


def test_samples_from_the_future_wait_for_their_step() -> None:
    sync = _stamped()
    _offer(sync, 20, 15)
    assert sync.ready(10)  # newer ones are here: 10 will not come
    assert sync.use(10) is None  # never a sample from the future
    assert sync.pending.keys() == {15, 20}
    assert sync.use(15) == b"s15"
    assert sync.use(20) == b"s20"
    counts = sync.finish()
    assert (counts.matched, counts.stale, counts.dropped) == (2, 1, 1)


def test_nothing_expected_loads_nothing() -> None:
    sync = _stamped()
    _offer(sync, 0)
    assert sync.ready(None)
    assert sync.use(None) is None
    assert sync.finish().matched == 0


def test_headerless_samples_without_a_source_timestamp_are_taken_by_arrival() -> None:
    sync = _stamped(Match.SOURCE)
    sync.offer(b"a", None)
    sync.offer(b"b", None)
    assert sync.match is Match.ARRIVAL
    assert sync.ready(40)
    assert sync.use(40) == b"b"
    assert sync.use(45) is None
    assert sync.finish().as_json()["match"] == "arrival"


def test_a_source_timestamp_outside_the_run_is_no_simulated_time_and_means_arrival() -> None:
    sync = StampedInput(Match.SOURCE, StepScale(0.0, 0.002, steps=1000))
    _offer(sync, 0, 5)
    assert sync.match is Match.SOURCE
    sync.offer(b"wall", 1_763_900_000 * 1_000_000_000)  # a wall clock: rclpy, or a negative start
    assert sync.match is Match.ARRIVAL
    assert sync.use(10) == b"wall"
    assert sync.finish().as_json()["match"] == "arrival"


def test_header_samples_are_placed_by_their_header_not_the_source_timestamp() -> None:
    codec = TopicCodec(
        "sensor_msgs/msg/Image", (PortField("front", (WHOLE,), (2, 2, 3), "uint8"),),
        RosDistro.HUMBLE,
    )  # fmt: skip
    sync = _stamped(Match.HEADER)
    frames = {
        k: codec.encode({"front": np.full((2, 2, 3), k, np.uint8)}, k * 0.002) for k in (1, 51)
    }
    sync.offer(frames[51], 1 * NS)  # a wrong source timestamp is ignored
    sync.offer(frames[1], None)
    assert sync.use(1) == frames[1]
    assert sync.use(51) == frames[51]
    assert sync.finish().matched == 2


def test_the_values_after_set_up_are_taken_for_the_start_without_counting_a_step() -> None:
    """An ONNX node's outputs at the start time (issue #34) use the set-up sample; that is no
    step, so a free run's counts stay those of its steps."""
    sync = _stamped()
    assert sync.take_start(0) is None  # not here (yet): the start values stay
    _offer(sync, 0, 5)
    assert sync.take_start(0) == b"s0"
    assert sync.use(5) == b"s5"  # the first step's sample, as before
    counts = sync.finish()
    assert (counts.received, counts.matched, counts.stale, counts.dropped) == (2, 1, 0, 0)


def test_a_topic_matched_by_arrival_keeps_its_newest_sample_for_the_first_step() -> None:
    sync = _stamped(Match.ARRIVAL)
    sync.offer(b"a", None)
    assert sync.take_start(None) == b"a"
    assert sync.use(None) == b"a"
