"""ROS 2 distributions, without their message stores.

The compiled system names the distribution its ROS 2 plan is for; reading a compiled system
(a cached compile, a worker's case, a node) needs the names only, not rosbags' type stores,
which :mod:`.messages` builds when a plan is computed.
"""

from __future__ import annotations

import enum


class RosDistro(enum.StrEnum):
    """ROS 2 distributions whose wire formats differ (``ros_discovery_info`` GID size)."""

    HUMBLE = "humble"
    IRON = "iron"
    JAZZY = "jazzy"
    KILTED = "kilted"


#: The default distribution: the current LTS (the paper used Humble; `--ros-distro humble`).
DEFAULT_DISTRO = RosDistro.JAZZY
