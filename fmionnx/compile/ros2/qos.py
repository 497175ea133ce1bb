"""ROS 2 QoS profiles and their Cyclone DDS form.

Names and values follow ``rmw/qos_profiles.h``: ``default`` (RELIABLE, VOLATILE, KEEP_LAST 10)
and ``sensor_data`` (BEST_EFFORT, VOLATILE, KEEP_LAST 5) matter most; a RELIABLE reader does
not match a BEST_EFFORT writer, which is why one profile is chosen per topic, not per end.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Reliability(enum.StrEnum):
    """DDS reliability kinds by their ROS 2 names."""

    RELIABLE = "reliable"
    BEST_EFFORT = "best_effort"


class Durability(enum.StrEnum):
    """DDS durability kinds by their ROS 2 names."""

    VOLATILE = "volatile"
    TRANSIENT_LOCAL = "transient_local"


@dataclass(frozen=True, slots=True)
class QosProfile:
    """A resolved QoS profile: KEEP_LAST ``depth``, or KEEP_ALL when ``keep_all``."""

    reliability: Reliability = Reliability.RELIABLE
    durability: Durability = Durability.VOLATILE
    depth: int = 10
    keep_all: bool = False

    def describe(self) -> str:
        """``RELIABLE, VOLATILE, KEEP_LAST 10`` for messages and ``ros2 graph``."""
        history = "KEEP_ALL" if self.keep_all else f"KEEP_LAST {self.depth}"
        return f"{self.reliability.upper()}, {self.durability.upper()}, {history}"


#: Named profiles, as in ``rmw/qos_profiles.h`` (``system_default`` is treated as ``default``:
#: Cyclone's own defaults differ between readers and writers).
PROFILES: dict[str, QosProfile] = {
    "default": QosProfile(),
    "system_default": QosProfile(),
    "services_default": QosProfile(),
    "sensor_data": QosProfile(Reliability.BEST_EFFORT, Durability.VOLATILE, 5),
    "parameters": QosProfile(Reliability.RELIABLE, Durability.VOLATILE, 1000),
    "parameter_events": QosProfile(Reliability.RELIABLE, Durability.VOLATILE, 1000),
    "latched": QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1),
    "clock": QosProfile(Reliability.BEST_EFFORT, Durability.VOLATILE, 1),
}

#: QoS of the ``ros_discovery_info`` writer (rmw_cyclonedds_cpp ``rmw_context_impl_s::init``).
DISCOVERY_QOS = QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1)
#: ... and of its reader: KEEP_ALL, because the topic has no key and every participant's
#: latest sample must survive in one instance's history.
DISCOVERY_READER_QOS = QosProfile(
    Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1, keep_all=True
)
