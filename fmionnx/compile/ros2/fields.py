"""Where port values live in ROS 2 messages: part of the compiled ROS 2 plan.

The plan (compile time) decides which field paths each port fills; the codec (run time,
:mod:`fmionnx.backends.ros2.codec`) moves the values. Both speak these terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

IMAGE_TYPE = "sensor_msgs/msg/Image"
#: The field path that stands for "the whole message" (an image).
WHOLE = ""


@dataclass(frozen=True, slots=True)
class PortField:
    """Where one port's values live in a message: one path, or one scalar path per element."""

    port: str
    paths: tuple[str, ...]
    shape: tuple[int, ...] = ()
    dtype: str = "float64"

    @property
    def size(self) -> int:
        """Number of elements of the port."""
        return math.prod(self.shape)


def image_geometry(shape: tuple[int, ...]) -> tuple[int, int, int] | None:
    """``(height, width, channels)`` of an image port (``[H,W,3]`` or ``[1,H,W,3]``), or None."""
    dims = shape[1:] if len(shape) == 4 and shape[0] == 1 else shape
    if len(dims) == 3 and dims[2] in (1, 3, 4) and all(isinstance(d, int) for d in dims):
        return int(dims[0]), int(dims[1]), int(dims[2])
    return None
