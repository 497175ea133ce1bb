"""``fmionnx run --backend ros2 --record``: the wire recorded as a ros2 MCAP bag, read back with
rosbags' own deserializer (independent of our codec), and the ROS 2 facts in run.json."""

from __future__ import annotations

import json
import os
import subprocess
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from tests.conftest import REPO, built_model
from tests.ros2.conftest import SESSION_DOMAIN
from tests.ros2.test_run import fmionnx

pytestmark = pytest.mark.ros2

SYSTEM = REPO / "systems" / "sign_follower.yaml"
STOP = 1.0
BASE_STEP = 0.002


@pytest.fixture(scope="module")
def loopback_module_env() -> Iterator[None]:
    """The loopback environment of ``loopback_env``, for one run shared by a module."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ROS_DOMAIN_ID", str(SESSION_DOMAIN))
        patch.setenv("ROS_LOCALHOST_ONLY", "1")
        patch.delenv("CYCLONEDDS_URI", raising=False)
        patch.delenv("ROS_AUTOMATIC_DISCOVERY_RANGE", raising=False)
        yield


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory, loopback_module_env: None) -> Path:
    built_model("ReadOdometry.fmu")
    out = tmp_path_factory.mktemp("record")
    done = subprocess.run(
        fmionnx("run", SYSTEM, "--no-checks", "--backend", "ros2", "--sync", "lockstep",
                "--stop-time", str(STOP), "--out", out, "--record", out / "wire.mcap"),
        capture_output=True, text=True, timeout=240, check=False,
        env={**os.environ, "COLUMNS": "400"},  # the table holds the whole, long path
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "wire.mcap" in " ".join(done.stderr.split())  # the summary lists the file
    return out


def _messages(path: Path) -> list[tuple[str, str, str, str, bytes]]:
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros2"
        return [
            (ch.topic, ch.message_encoding, sc.name, sc.encoding, msg.data)
            for sc, ch, msg in reader.iter_messages()
            if sc is not None
        ]


def test_record_writes_every_topic_as_cdr_with_ros2msg_schemas(recorded: Path) -> None:
    messages = _messages(recorded / "wire.mcap")
    counts = Counter(topic for topic, *_ in messages)
    assert {"/clock", "/cmd_vel", "/odom", "/camera/image_raw"} <= set(counts)
    assert {(enc, schema_enc) for _, enc, _, schema_enc, _ in messages} == {("cdr", "ros2msg")}
    types = {topic: name for topic, _, name, *_ in messages}
    assert types["/cmd_vel"] == "geometry_msgs/msg/Twist"
    assert types["/camera/image_raw"] == "sensor_msgs/msg/Image"
    # lockstep: one /clock per base step plus the final one, one Twist per tracker period
    assert counts["/clock"] == round(STOP / BASE_STEP) + 1


def test_recorded_bytes_deserialize_with_rosbags(recorded: Path) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    images, twists = [], []
    for topic, _, msgtype, _, data in _messages(recorded / "wire.mcap"):
        message = store.deserialize_cdr(data, msgtype)  # raises on a malformed sample
        if topic == "/camera/image_raw":
            images.append(message)
        elif topic == "/cmd_vel":
            twists.append(message)
    assert images
    assert twists
    first = images[0]
    assert (first.height, first.width, first.encoding, first.step) == (480, 640, "rgb8", 1920)
    assert first.data.size == 480 * 640 * 3
    assert any(t.linear.x != 0.0 or t.angular.z != 0.0 for t in twists)


def test_run_json_says_how_the_ros2_run_executed(recorded: Path) -> None:
    info = json.loads((recorded / "run.json").read_text(encoding="utf-8"))
    execution = info["execution"]
    assert execution["sync"] == "lockstep"
    assert execution["ros_distro"] == "jazzy"  # the default
    assert execution["middleware"] == "dds"
    assert execution["zenoh_router"] is None
    assert "/fmu_sign_tracking_node" in execution["nodes"]
    assert execution["record"].endswith("wire.mcap")
    assert execution["recorded_messages"] == len(_messages(recorded / "wire.mcap"))
