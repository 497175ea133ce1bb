"""ROS 2 wire benchmarks on loopback: serialisation, Twist and Image hops, 30 Hz throughput.

Run: ``python benchmarks/ros2_wire.py`` (spawns one echo process; domain chosen at random,
traffic kept on 127.0.0.1). A hop is half of a ping -> echo -> pong round trip between two
processes, each side serialising and deserialising as a node does. Prints a table.
"""

from __future__ import annotations

import os
import random
import statistics
import subprocess
import sys
import time
from typing import Any

import numpy as np

from fmionnx.backends.ros2.codec import WHOLE, PortField, TopicCodec
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES

IMAGE = "sensor_msgs/msg/Image"
TWIST = "geometry_msgs/msg/Twist"
DISTRO = RosDistro.HUMBLE


def _codecs() -> dict[str, TopicCodec]:
    return {
        TWIST: TopicCodec(TWIST, (PortField("v", ("linear.x",)),), DISTRO),
        IMAGE: TopicCodec(IMAGE, (PortField("img", (WHOLE,), (480, 640, 3), "uint8"),), DISTRO),
    }


def echo() -> None:
    """Child: decode every ping and publish it back re-encoded (a node's full path)."""
    with Participant(from_environment(DISTRO)) as participant:
        echo_on(participant)


def echo_on(participant: Any, seconds: float = 120.0) -> None:
    """Echo pings on any node transport (Cyclone here, Zenoh in ``ros2_zenoh.py``)."""
    codecs = _codecs()
    pairs = []
    for msgtype, name in ((TWIST, "twist"), (IMAGE, "image")):
        reader = participant.reader(f"rt/ping_{name}", msgtype, PROFILES["default"])
        writer = participant.writer(f"rt/pong_{name}", msgtype, PROFILES["default"])
        pairs.append((reader, writer, codecs[msgtype]))
    print("ready", flush=True)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        for reader, writer, codec in pairs:
            for data in reader.take():
                values, stamp = codec.decode(data)
                writer.write(codec.encode(values, stamp or 0.0))
        time.sleep(0.0002)


def _percentiles(samples: list[float]) -> tuple[float, float]:
    ordered = sorted(samples)
    return statistics.median(ordered), ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]


def _hops(
    participant: Any, name: str, msgtype: str, values: dict[str, np.ndarray], count: int
) -> list[float]:
    codec = _codecs()[msgtype]
    writer = participant.writer(f"rt/ping_{name}", msgtype, PROFILES["default"])
    reader = participant.reader(f"rt/pong_{name}", msgtype, PROFILES["default"])
    writer.wait_for_readers(1, 20)
    while reader.matched() < 1:
        time.sleep(0.01)
    hops = []
    for _ in range(count):
        start = time.perf_counter()
        writer.write(codec.encode(values))
        got: list[bytes] = []
        while not got:
            reader.wait(1.0)
            got = reader.take()
        codec.decode(got[-1])
        hops.append((time.perf_counter() - start) / 2 * 1e3)
    return hops


def _throughput(
    participant: Any, rate: float, seconds: float, frame: np.ndarray
) -> tuple[int, int]:
    codec = _codecs()[IMAGE]
    writer = participant.writer("rt/ping_image", IMAGE, PROFILES["default"])
    reader = participant.reader("rt/pong_image", IMAGE, PROFILES["default"])
    writer.wait_for_readers(1, 20)
    sent = received = 0
    period = 1.0 / rate
    next_time = time.monotonic()
    end = next_time + seconds
    while time.monotonic() < end:
        now = time.monotonic()
        if now >= next_time:
            writer.write(codec.encode({"img": frame}))
            sent += 1
            next_time += period
        received += len(reader.take())
        time.sleep(0.001)
    deadline = time.monotonic() + 2
    while received < sent and time.monotonic() < deadline:
        reader.wait(0.2)
        received += len(reader.take())
    return sent, received


def main() -> None:
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(100, 230)))
    os.environ["ROS_LOCALHOST_ONLY"] = "1"
    frame = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    codec = _codecs()[IMAGE]
    encode_ms = []
    for _ in range(50):
        start = time.perf_counter()
        data = codec.encode({"img": frame})
        encode_ms.append((time.perf_counter() - start) * 1e3)
    decode_ms = []
    for _ in range(50):
        start = time.perf_counter()
        codec.decode(data)
        decode_ms.append((time.perf_counter() - start) * 1e3)
    rows = [
        ("640x480 rgb8 Image encode (ms)", *_percentiles(encode_ms)),
        ("640x480 rgb8 Image decode (ms)", *_percentiles(decode_ms)),
    ]
    child = subprocess.Popen(
        [sys.executable, __file__, "--echo"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        child.stdout.readline()
        with Participant(from_environment(DISTRO)) as participant:
            twist = _hops(participant, "twist", TWIST, {"v": np.array(0.5)}, 500)
            image = _hops(participant, "image", IMAGE, {"img": frame}, 100)
            rows.append(("Twist hop, process to process (ms)", *_percentiles(twist)))
            rows.append(("Image hop, process to process (ms)", *_percentiles(image)))
            print(f"{'measurement':<44}{'p50':>10}{'p99':>10}")
            for label, p50, p99 in rows:
                print(f"{label:<44}{p50:>10.3f}{p99:>10.3f}")
            print(f"{'image echo (every frame back?)':<44}{'sent':>10}{'back':>10}")
            for rate in (10.0, 30.0):
                sent, received = _throughput(participant, rate, 3.0, frame)
                print(f"{f'640x480 rgb8 at {rate:.0f} Hz for 3 s':<44}{sent:>10}{received:>10}")
    finally:
        child.kill()
        child.wait()


if __name__ == "__main__":
    if "--echo" in sys.argv:
        echo()
    else:
        main()
