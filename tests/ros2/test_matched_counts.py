"""A writer's and a reader's matched counts, as the run's start waits on them: each counts
the other side's endpoints as they match and as they go, in other participants too.

The count is read from the endpoint's matched status. Cyclone's Python binding lists the
matched endpoints in two calls (a count, then that many handles) and raised ``IndexError``
when one matched between the two: a node of a starting lockstep run faulted so in CI.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest

from fmionnx.backends.ros2.env import DdsEnvironment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.qos import PROFILES

pytestmark = pytest.mark.ros2

TOPIC = "rt/fmionnx_matched_counts"
FLOAT64 = "std_msgs/msg/Float64"


def _reaches(count: Callable[[], int], wanted: int, timeout: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout
    while count() != wanted:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def test_matched_counts_follow_the_endpoints_on_both_sides(loopback_env: DdsEnvironment) -> None:
    qos = PROFILES["default"]
    with Participant(loopback_env) as ours, Participant(loopback_env) as theirs:
        writer = ours.writer(TOPIC, FLOAT64, qos)
        assert writer.matched() == 0
        first = theirs.reader(TOPIC, FLOAT64, qos)
        second = ours.reader(TOPIC, FLOAT64, qos)
        assert _reaches(writer.matched, 2)
        assert _reaches(first.matched, 1)
        assert _reaches(second.matched, 1)
        theirs.close()  # the first reader goes with its participant
        assert _reaches(writer.matched, 1)
        assert writer.wait_for_readers(1, 5.0)
