"""The run's control topics: ``/clock``, and the supervisor's ``ready`` and ``done`` hand-shake.

``/clock`` is ROS 2's simulated time (``rosgraph_msgs/msg/Clock``); every node runs on it.
Two private topics, in the ``/fmionnx`` namespace so that they never clash with a user's:

* ``/fmionnx/ready`` (``std_msgs/msg/String``, ``data`` = component): the node has set up its
  model, matched its readers and published its initial values;
* ``/fmionnx/done`` (``std_msgs/msg/Header``, ``frame_id`` = component, ``stamp`` = ``t_n``):
  lockstep only, the node finished its step at ``t_n`` and published its outputs.

All three are RELIABLE and TRANSIENT_LOCAL: a lost tick or done would stall a lockstep run, and
a reader that matches late (a foreign ``/clock`` subscriber can satisfy a writer's wait for
readers) still gets the recent samples. A ROS 2 subscriber of ``/clock`` with the usual
best-effort, volatile clock QoS still matches such a writer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fmionnx.compile.ir import RunSettings
from fmionnx.compile.ros2.messages import RosDistro, default_message, deserialize, serialize
from fmionnx.compile.ros2.names import dds_topic
from fmionnx.compile.ros2.plan import CLOCK_TOPIC, CLOCK_TYPE
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability

READY_TOPIC = "/fmionnx/ready"
READY_TYPE = "std_msgs/msg/String"
DONE_TOPIC = "/fmionnx/done"
DONE_TYPE = "std_msgs/msg/Header"

#: Writers keep a few samples; readers keep everything until taken (nothing may be lost).
CONTROL_WRITER_QOS = QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 64)
CONTROL_READER_QOS = QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 64, keep_all=True)

CLOCK_DDS = dds_topic(CLOCK_TOPIC)
READY_DDS = dds_topic(READY_TOPIC)
DONE_DDS = dds_topic(DONE_TOPIC)


def _time_fields(seconds: float) -> tuple[int, int]:
    sec = int(np.floor(seconds))
    nanosec = round((seconds - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return sec, nanosec


@dataclass(frozen=True, slots=True)
class StepClock:
    """Base-step index <-> ``/clock`` time for one run (``t_n = start + n * step``)."""

    run: RunSettings
    distro: RosDistro

    def encode(self, n: int) -> bytes:
        """A ``Clock`` sample holding ``t_n``."""
        message = default_message(CLOCK_TYPE, self.distro)
        message.clock.sec, message.clock.nanosec = _time_fields(self.run.time_at(n))
        return serialize(message, CLOCK_TYPE, self.distro)

    def decode(self, data: bytes) -> int:
        """The base step of a ``Clock`` sample (nearest grid point)."""
        stamp = deserialize(data, CLOCK_TYPE, self.distro).clock
        seconds = float(stamp.sec) + float(stamp.nanosec) * 1e-9
        return round((seconds - self.run.start) / self.run.step)

    def encode_done(self, component: str, n: int) -> bytes:
        """A ``done`` sample: ``component`` finished its step at ``t_n``."""
        message = default_message(DONE_TYPE, self.distro)
        message.frame_id = component
        message.stamp.sec, message.stamp.nanosec = _time_fields(self.run.time_at(n))
        return serialize(message, DONE_TYPE, self.distro)

    def decode_done(self, data: bytes) -> tuple[str, int]:
        """Component and base step of a ``done`` sample."""
        message = deserialize(data, DONE_TYPE, self.distro)
        seconds = float(message.stamp.sec) + float(message.stamp.nanosec) * 1e-9
        return str(message.frame_id), round((seconds - self.run.start) / self.run.step)


def encode_ready(component: str, distro: RosDistro) -> bytes:
    """A ``ready`` sample for ``component``."""
    message = default_message(READY_TYPE, distro)
    message.data = component
    return serialize(message, READY_TYPE, distro)


def decode_ready(data: bytes, distro: RosDistro) -> str:
    """The component of a ``ready`` sample."""
    return str(deserialize(data, READY_TYPE, distro).data)
