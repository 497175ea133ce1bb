"""A camera relay that holds frames back (run as ``python relay_peer.py SRC DST HOLD``).

Subscribes ``sensor_msgs/msg/Image`` on ROS topic SRC, and republishes every frame on DST
HOLD seconds after it arrived, in order, keeping its header and source timestamp: the frames
reach their reader well after ``/clock`` passed their time, as across a slow link. The pixels
are replaced by a grey frame with one red square whose side names the frame
(:func:`side_of`), so that a detector's recorded output tells which frame it stepped on.
Prints ``{"ready": true}`` once subscribed, then one JSON line per frame forwarded; ends when
stdin closes. Reads ROS_DOMAIN_ID / ROS_LOCALHOST_ONLY like a ROS 2 process.
"""

from __future__ import annotations

import json
import select
import sys
import time
from collections import deque

import numpy as np

from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.inputsync import header_stamp_ns
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro, deserialize, serialize
from fmionnx.compile.ros2.names import dds_topic
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability

IMAGE = "sensor_msgs/msg/Image"
#: The reference system's camera period (s) and the offset of a frame's stamp from its step.
FRAME_PERIOD = 0.1
FRAME_OFFSET = 0.002


def frame_number(stamp_ns: int) -> int:
    """The detector step a frame belongs to (frames are stamped ``0.1 k + 0.002``)."""
    return round((stamp_ns * 1e-9 - FRAME_OFFSET) / FRAME_PERIOD)


def side_of(frame: int) -> int:
    """Side in pixels of the red square painted into frame ``frame`` (15 distinct sizes)."""
    return 60 + 10 * (frame % 15)


def painted(frame: int, height: int = 480, width: int = 640) -> np.ndarray:
    """The grey frame with the red square of ``frame``."""
    pixels = np.full((height, width, 3), 128, dtype=np.uint8)
    side = side_of(frame)
    pixels[100 : 100 + side, 200 : 200 + side] = (220, 20, 20)
    return pixels


def main() -> None:
    source, target, hold = sys.argv[1], sys.argv[2], float(sys.argv[3])
    distro = RosDistro.HUMBLE
    participant = Participant(from_environment(distro))
    qos = QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 10)
    reader = participant.reader(dds_topic(source), IMAGE, qos)
    writer = participant.writer(dds_topic(target), IMAGE, qos)
    print(json.dumps({"ready": True}), flush=True)
    held: deque[tuple[float, bytes, int | None, int]] = deque()
    try:
        while True:
            if select.select([sys.stdin], [], [], 0)[0] and not sys.stdin.readline():
                break
            reader.wait(0.005)
            for data, source_ns in reader.take_stamped():
                stamp = header_stamp_ns(data) or 0
                frame = frame_number(stamp)
                message = deserialize(data, IMAGE, distro)
                pixels = painted(frame, int(message.height), int(message.width))
                message.data = pixels.reshape(-1)
                held.append((time.monotonic() + hold, serialize(message, IMAGE, distro),
                             source_ns, frame))  # fmt: skip
            while held and held[0][0] <= time.monotonic():
                _, payload, source_ns, frame = held.popleft()
                writer.write(payload, source_ns)
                print(json.dumps({"frame": frame, "side": side_of(frame)}), flush=True)
    finally:
        participant.close()


if __name__ == "__main__":
    main()
