"""An independent rmw_zenoh client in a child process: ``zenoh-ros2-sdk`` from PyPI.

``python sdk_peer.py twist-sub PORT COUNT``: subscribes to ``/cmd_vel`` (Twist) through the
router on 127.0.0.1:PORT and prints every message as a JSON line, after ``{"ready": true}``.
``python sdk_peer.py image-pub PORT COUNT``: publishes COUNT 640x480 rgb8 images on
``/camera/image_raw`` at 10 Hz (grey, with a red board), after ``{"ready": true}``.

The SDK would fetch message definitions from git repositories; this machine has no network,
so the definitions and type hashes come from rosbags' Jazzy type store (the ROS 2 sources'
own text), handed to the SDK as it documents (``msg_definition``, ``type_hash``).
ROS_DOMAIN_ID selects the domain, as for any ROS 2 process.
"""

import json
import sys
import time

import numpy as np
from rosbags.typesys import Stores, get_typestore
from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber
from zenoh_ros2_sdk.session import ZenohSession

STORE = get_typestore(Stores.ROS2_JAZZY)

#: Own definitions (no comments): what the SDK parses.
DEFINITIONS = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Twist": "Vector3 linear\nVector3 angular\n",
    "sensor_msgs/msg/Image": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data\n"
    ),
}


def _register(port: int, *types: str) -> None:
    session = ZenohSession.get_instance("127.0.0.1", port)
    for msgtype in types:
        session.register_message_type(DEFINITIONS[msgtype], msgtype)


def twist_sub(port: int, count: int) -> None:
    _register(port, "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Twist")
    received: list[dict[str, float]] = []

    def on_message(msg: object) -> None:
        line = {"x": float(msg.linear.x), "w": float(msg.angular.z)}  # type: ignore[attr-defined]
        received.append(line)
        print(json.dumps(line), flush=True)

    subscriber = ROS2Subscriber(
        topic="/cmd_vel", msg_type="geometry_msgs/msg/Twist",
        msg_definition=DEFINITIONS["geometry_msgs/msg/Twist"], callback=on_message,
        node_name="sdk_twist_listener", router_port=port,
        type_hash=STORE.hash_rihs01("geometry_msgs/msg/Twist"),
    )  # fmt: skip
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + 120
    while len(received) < count and time.monotonic() < deadline:
        time.sleep(0.05)
    subscriber.close()


def image_pub(port: int, count: int) -> None:
    _register(port, "builtin_interfaces/msg/Time", "std_msgs/msg/Header", "sensor_msgs/msg/Image")
    publisher = ROS2Publisher(
        topic="/camera/image_raw", msg_type="sensor_msgs/msg/Image",
        msg_definition=DEFINITIONS["sensor_msgs/msg/Image"], node_name="sdk_camera",
        router_port=port, type_hash=STORE.hash_rihs01("sensor_msgs/msg/Image"),
    )  # fmt: skip
    types = publisher.session_mgr.store.types
    header_class, time_class = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    print(json.dumps({"ready": True}), flush=True)
    board = np.full((480, 640, 3), 128, dtype=np.uint8)
    board[100:300, 200:400] = (220, 20, 20)
    frame = board.reshape(-1)
    for n in range(count):
        publisher.publish(
            header=header_class(stamp=time_class(sec=n, nanosec=0), frame_id="camera"),
            height=480, width=640, encoding="rgb8", is_bigendian=0, step=640 * 3, data=frame,
        )  # fmt: skip
        time.sleep(0.1)
    publisher.close()


if __name__ == "__main__":
    role, port_text, count_text = sys.argv[1:4]
    {"twist-sub": twist_sub, "image-pub": image_pub}[role](int(port_text), int(count_text))
