"""Child processes for the wire tests (run as ``python peers.py ROLE``).

``twist-sub``: an independent subscriber written directly on ``cyclonedds`` with its own IDL
types in ROS 2 naming; prints every ``rt/cmd_vel`` sample as a JSON line.
``announce``: a fmionnx participant announcing two nodes on ``ros_discovery_info``; prints the
GUIDs of its participant, readers and writers, then waits for stdin to close.
Both read ROS_DOMAIN_ID / ROS_LOCALHOST_ONLY like a ROS 2 process.
"""

# No `from __future__ import annotations`: cyclonedds resolves member types at class creation.
import json
import sys
import threading
import time
from dataclasses import dataclass

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as t
from cyclonedds.idl.annotations import final
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@final
@dataclass
class Vector3_(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):  # noqa: N801
    x: t.float64
    y: t.float64
    z: t.float64


@final
@dataclass
class Twist_(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):  # noqa: N801
    linear: Vector3_
    angular: Vector3_


#: Seconds after which a subscriber gives up: a bound on a hung test, not a timing.
HANG_SECONDS = 600


def twist_sub(count: int) -> None:
    import os

    domain_id = int(os.environ["ROS_DOMAIN_ID"])
    loopback = (
        '<CycloneDDS><Domain><General><Interfaces><NetworkInterface address="127.0.0.1"/>'
        "</Interfaces></General></Domain></CycloneDDS>"
    )
    domain = Domain(domain_id, loopback)
    participant = DomainParticipant(domain_id)
    qos = Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )
    reader = DataReader(participant, Topic(participant, "rt/cmd_vel", Twist_), qos=qos)
    print(json.dumps({"ready": True}), flush=True)
    received = 0
    # Until COUNT samples, or (with --until-eof) until the test closes stdin, the run being
    # over, and the samples still on their way are taken: never a wall-clock deadline, which a
    # loaded machine's run outlasts. HANG_SECONDS only bounds a test that went wrong.
    ended = threading.Event()
    if "--until-eof" in sys.argv:
        threading.Thread(target=lambda: (sys.stdin.read(), ended.set()), daemon=True).start()
    deadline = time.monotonic() + HANG_SECONDS
    quiet_since = time.monotonic()
    while received < count and time.monotonic() < deadline:
        samples = reader.take(10)
        for sample in samples:
            print(json.dumps({"x": sample.linear.x, "z": sample.angular.z}), flush=True)
            received += 1
        if samples:
            quiet_since = time.monotonic()
        elif ended.is_set() and time.monotonic() - quiet_since > 1.0:
            break
        time.sleep(0.005)
    del reader, participant, domain


def announce() -> None:
    from fmionnx.backends.ros2.discovery import GraphAnnouncer, NodeEntities
    from fmionnx.backends.ros2.env import from_environment
    from fmionnx.backends.ros2.transport import Participant
    from fmionnx.compile.ros2.messages import RosDistro
    from fmionnx.compile.ros2.qos import PROFILES

    distro = RosDistro(sys.argv[2])
    participant = Participant(from_environment(distro))
    twist = "geometry_msgs/msg/Twist"
    writer = participant.writer("rt/cmd_vel", twist, PROFILES["default"])
    reader = participant.reader("rt/odom", "nav_msgs/msg/Odometry", PROFILES["default"])
    other = participant.reader("rt/camera/image_raw", "sensor_msgs/msg/Image", PROFILES["default"])
    announcer = GraphAnnouncer(participant)
    announcer.add_node(NodeEntities("/", "fmu_sign_tracking_node", [reader.gid], [writer.gid]))
    announcer.add_node(NodeEntities("/robot", "detector", [other.gid], []))
    print(
        json.dumps(
            {
                "participant": participant.gid.hex(),
                "writer": writer.gid.hex(),
                "reader": reader.gid.hex(),
                "other": other.gid.hex(),
            }
        ),
        flush=True,
    )
    sys.stdin.read()
    participant.close()


if __name__ == "__main__":
    if sys.argv[1] == "twist-sub":
        twist_sub(int(sys.argv[2]))
    else:
        announce()
