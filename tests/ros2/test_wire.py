"""Wire compatibility on real DDS: separate processes on loopback, a random domain."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from fmionnx.backends.ros2.codec import WHOLE, PortField, TopicCodec
from fmionnx.backends.ros2.discovery import GraphListener
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES

PEERS = Path(__file__).with_name("peers.py")

pytestmark = pytest.mark.ros2


def _spawn(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, str(PEERS), *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.fixture
def children() -> Iterator[list[subprocess.Popen[str]]]:
    """Child processes that are always reaped, whatever the test does."""
    started: list[subprocess.Popen[str]] = []
    yield started
    for child in started:
        if child.poll() is None:
            child.kill()
        child.wait(timeout=10)
        for stream in (child.stdin, child.stdout, child.stderr):
            if stream is not None:
                stream.close()


def _line(child: subprocess.Popen[str]) -> dict[str, object]:
    assert child.stdout is not None
    line = child.stdout.readline()
    if not line:
        assert child.stderr is not None
        pytest.fail(f"peer exited: {child.stderr.read()[-2000:]}")
    return json.loads(line)


def test_independent_cyclonedds_subscriber_receives_twist_on_rt_cmd_vel(loopback_env, children):
    child = _spawn("twist-sub", "3")
    children.append(child)
    assert _line(child) == {"ready": True}
    with Participant(loopback_env) as participant:
        writer = participant.writer("rt/cmd_vel", "geometry_msgs/msg/Twist", PROFILES["default"])
        assert writer.wait_for_readers(1, timeout=10), "no subscriber matched (type or QoS)"
        codec = TopicCodec(
            "geometry_msgs/msg/Twist",
            (PortField("v", ("linear.x",)), PortField("w", ("angular.z",))),
            RosDistro.HUMBLE,
        )
        for i in range(3):
            writer.write(codec.encode({"v": np.array(0.1 * i), "w": np.array(-0.5)}))
        received = [_line(child) for _ in range(3)]
    assert received == [{"x": 0.1 * i, "z": -0.5} for i in range(3)]


@pytest.mark.parametrize("distro", ["humble", "jazzy"])
def test_discovery_info_lists_every_node_with_its_readers_and_writers(
    loopback_env, children, monkeypatch, distro
):
    # Humble and Jazzy derive different Cyclone settings from ROS_LOCALHOST_ONLY, and one
    # process holds one configuration per domain: each distribution gets its own domain.
    if distro == "jazzy":
        monkeypatch.setenv("ROS_DOMAIN_ID", str(loopback_env.domain_id + 1))
    env = from_environment(RosDistro(distro))
    child = _spawn("announce", distro)
    children.append(child)
    gids = {k: bytes.fromhex(str(v)) for k, v in _line(child).items()}
    with Participant(env) as participant:
        listener = GraphListener(participant)
        nodes = listener.wait_for({"/fmu_sign_tracking_node", "/robot/detector"}, timeout=10)
        by_name = {n.fqn: n for n in nodes}
        assert set(by_name) == {"/fmu_sign_tracking_node", "/robot/detector"}
        tracker = by_name["/fmu_sign_tracking_node"]
        assert (tracker.readers, tracker.writers) == ([gids["reader"]], [gids["writer"]])
        assert by_name["/robot/detector"].readers == [gids["other"]]
        assert list(listener.participants) == [gids["participant"]]


def test_rgb8_image_crosses_dds_bit_exact(loopback_env):
    frame = np.random.default_rng(2).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    codec = TopicCodec(
        "sensor_msgs/msg/Image",
        (PortField("img", (WHOLE,), (480, 640, 3), "uint8"),),
        RosDistro.HUMBLE,
    )
    with Participant(loopback_env) as sender, Participant(loopback_env) as receiver:
        reader = receiver.reader(
            "rt/camera/image_raw", "sensor_msgs/msg/Image", PROFILES["default"]
        )
        writer = sender.writer("rt/camera/image_raw", "sensor_msgs/msg/Image", PROFILES["default"])
        assert writer.wait_for_readers(1, timeout=10)
        writer.write(codec.encode({"img": frame}, stamp=1.5))
        deadline = time.monotonic() + 10
        samples: list[bytes] = []
        while not samples and time.monotonic() < deadline:
            reader.wait(0.5)
            samples = reader.take()
    values, stamp = codec.decode(samples[0])
    np.testing.assert_array_equal(values["img"], frame.reshape(-1))
    assert stamp == 1.5
