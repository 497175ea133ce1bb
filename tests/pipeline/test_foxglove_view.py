"""``--view foxglove``: a WebSocket client receives the run's channels and decodes them.

The reference scenario runs paced at real time (so that the client, connecting once the
server is up, sees it go) with the server on a free port, which the run names on stderr. The
client speaks Foxglove's WebSocket protocol (``foxglove.sdk.v1``): it subscribes to every
channel advertised and decodes one camera frame (ROS 2 ``sensor_msgs/msg/Image``, CDR, with
rosbags) and one ``/signals`` message (JSON), and checks that the schemas are the MCAP
recording's (one description of the channels, :mod:`fmionnx.results.channels`).
"""

from __future__ import annotations

import asyncio
import json
import re
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fmionnx.results import channels
from tests.conftest import finish

websockets = pytest.importorskip("websockets")
pytest.importorskip("foxglove")

REPO = Path(__file__).resolve().parents[2]
SUBPROTOCOL = "foxglove.sdk.v1"


def _port(process: subprocess.Popen[str]) -> int:
    """The port the run names on stderr (``foxglove: serving ws://127.0.0.1:PORT``)."""
    assert process.stderr is not None
    deadline = time.monotonic() + 240
    seen = []
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line:
            break
        seen.append(line)
        found = re.search(r"foxglove: serving ws://127\.0\.0\.1:(\d+)", line)
        if found:
            return int(found[1])
    process.kill()
    pytest.fail("the run never named its server:\n" + "".join(seen[-20:]))


async def _receive(
    port: int, wanted: set[str]
) -> tuple[dict[str, dict[str, object]], dict[str, bytes]]:
    """Subscribe to every channel; return the advertisements and the first message of each
    ``wanted`` topic."""
    advertised: dict[str, dict[str, object]] = {}
    first: dict[str, bytes] = {}
    by_subscription: dict[int, str] = {}
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL]) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        while not wanted <= set(first):
            message = await asyncio.wait_for(ws.recv(), 60)
            if isinstance(message, str):
                data = json.loads(message)
                if data.get("op") != "advertise":
                    continue
                for channel in data["channels"]:
                    advertised[channel["topic"]] = channel
                    key = len(by_subscription) + 1
                    by_subscription[key] = channel["topic"]
                    subscription = {"id": key, "channelId": channel["id"]}
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": [subscription]}))
            elif message[0] == 1:  # message data: subscription id, log time, payload
                key, _ = struct.unpack_from("<IQ", message, 1)
                first.setdefault(by_subscription[key], bytes(message[13:]))
    return advertised, first


def test_a_websocket_client_decodes_an_image_and_a_signal() -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "fmionnx", "run", str(REPO / "systems" / "sign_follower.yaml"),
         "--stop-time", "4", "--rtf", "1", "--no-out", "--no-checks", "--view", "foxglove:0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        port = _port(process)
        advertised, first = asyncio.run(_receive(port, {"/world/front", "/signals"}))
    finally:
        _, err = finish(process, 240)
    assert process.returncode == 0, err[-3000:]

    image_channel = advertised["/world/front"]
    assert image_channel["schemaName"] == "sensor_msgs/msg/Image"
    assert image_channel["encoding"] == "cdr"
    assert image_channel["schemaEncoding"] == "ros2msg"
    assert (
        image_channel["schema"] == channels.ImageCodec().channel("world", "front").schema.decode()
    )
    from rosbags.typesys import Stores, get_typestore

    image = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr(
        first["/world/front"], channels.IMAGE_TYPE
    )
    assert (image.height, image.width, image.encoding) == (480, 640, "rgb8")
    assert image.data.size == 480 * 640 * 3
    assert image.header.frame_id == "world/front"

    signals_channel = advertised["/signals"]
    assert (signals_channel["schemaName"], signals_channel["encoding"]) == (
        "fmionnx.Signals",
        "json",
    )
    row = json.loads(first["/signals"])
    assert isinstance(row["time"], float)
    assert isinstance(row["odometry.posX"], float)
    assert isinstance(row["tracker.v"], float)
    for topic in ("/map", "/graph", "/trajectory"):
        assert topic in advertised, sorted(advertised)
