"""Real ROS 2 client-library peers for the interop tests (run as ``python rclpy_peer.py ROLE``).

Each role is an ordinary rclpy program, the kind a ROS 2 user would write; it runs in its own
process so that rclpy (and Fast DDS) never load into the pytest process.

``graph TIMEOUT NAME...``: spins until every fully qualified node name is in rclpy's graph and
has topics, then prints one JSON object: node names and, per node, its publishers and
subscribers as rclpy reports them.
``twist-sub COUNT TIMEOUT``: prints ``{"ready": true}``, then one JSON line per ``/cmd_vel``
``geometry_msgs/msg/Twist`` received (up to COUNT); ends 3 s after the last one.
``image-pub TIMEOUT``: publishes a 640x480 ``rgb8`` image with a red board on
``/camera/image_raw`` every 0.1 s until the first ``/onnx_blobSize`` sample with a red size
above zero arrives, prints that size as JSON and exits.
Domain and discovery range come from ROS_DOMAIN_ID / ROS_AUTOMATIC_DISCOVERY_RANGE, as usual.
"""

import json
import sys
import time

import rclpy
from rclpy.node import Node


def _fqn(namespace: str, name: str) -> str:
    return namespace.rstrip("/") + "/" + name


def graph(timeout: float, wanted: set[str]) -> None:
    node = rclpy.create_node("fmionnx_interop_graph_probe")
    deadline = time.monotonic() + timeout
    report: dict[str, object] = {}
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.2)
        names = node.get_node_names_and_namespaces()
        fqns = {_fqn(ns, name): (name, ns) for name, ns in names}
        if not wanted <= set(fqns):
            continue
        pubs = {f: node.get_publisher_names_and_types_by_node(*fqns[f]) for f in wanted}
        subs = {f: node.get_subscriber_names_and_types_by_node(*fqns[f]) for f in wanted}
        report = {"nodes": sorted(fqns), "publishers": pubs, "subscribers": subs}
        if all(pubs[f] or subs[f] for f in wanted):
            break
    if not report:
        names = node.get_node_names_and_namespaces()
        report = {"nodes": sorted(_fqn(ns, name) for name, ns in names)}
    print(json.dumps(report), flush=True)
    node.destroy_node()


def twist_sub(count: int, timeout: float) -> None:
    from geometry_msgs.msg import Twist

    node = rclpy.create_node("fmionnx_interop_cmd_vel_listener")
    received: list[Twist] = []
    node.create_subscription(Twist, "/cmd_vel", received.append, 10)
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + timeout
    quiet_until = deadline  # the run is over once /cmd_vel has been quiet for 3 s
    printed = 0
    while printed < count and time.monotonic() < min(deadline, quiet_until):
        rclpy.spin_once(node, timeout_sec=0.1)
        for message in received[printed:count]:
            print(json.dumps({"x": message.linear.x, "z": message.angular.z}), flush=True)
            quiet_until = time.monotonic() + 3.0
        printed = min(len(received), count)
    node.destroy_node()


def image_pub(timeout: float) -> None:
    import numpy as np
    from sensor_msgs.msg import Image
    from std_msgs.msg import Float64MultiArray

    node: Node = rclpy.create_node("fmionnx_interop_camera")
    publisher = node.create_publisher(Image, "/camera/image_raw", 10)
    sizes: list[float] = []

    def on_blob(message: Float64MultiArray) -> None:
        if message.data[0] > 0:
            sizes.append(float(message.data[0]))

    node.create_subscription(Float64MultiArray, "/onnx_blobSize", on_blob, 10)
    frame = np.full((480, 640, 3), 128, dtype=np.uint8)
    frame[100:300, 200:400] = (220, 20, 20)  # a red board
    image = Image(height=480, width=640, encoding="rgb8", is_bigendian=0, step=640 * 3)
    image.header.frame_id = "camera"
    image.data = frame.tobytes()
    deadline = time.monotonic() + timeout
    next_publish = 0.0
    while not sizes and time.monotonic() < deadline:
        if time.monotonic() >= next_publish:
            publisher.publish(image)
            next_publish = time.monotonic() + 0.1
        rclpy.spin_once(node, timeout_sec=0.05)
    print(json.dumps({"red": sizes[0] if sizes else None}), flush=True)
    node.destroy_node()


if __name__ == "__main__":
    rclpy.init(args=["rclpy_peer", "--ros-args", "--disable-external-lib-logs"])  # no ~/.ros/log
    try:
        role = sys.argv[1]
        if role == "graph":
            graph(float(sys.argv[2]), set(sys.argv[3:]))
        elif role == "twist-sub":
            twist_sub(int(sys.argv[2]), float(sys.argv[3]))
        else:
            image_pub(float(sys.argv[2]))
    finally:
        rclpy.try_shutdown()
