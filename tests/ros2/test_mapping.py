"""Default mapping of ports onto topics and the checks of the ``ros2:`` section (E060..E065)."""

from __future__ import annotations

import pytest

from fmionnx.compile.ros2.plan import build_plan, check_ros2
from fmionnx.compile.ros2.qos import PROFILES
from fmionnx.spec.model import QosSpec, Ros2Spec, TopicSpec

from .conftest import make_system


def test_reference_system_maps_without_a_ros2_section(reference_system):
    plan, diagnostics = build_plan(reference_system)
    assert diagnostics == []
    assert plan is not None
    topics = {t.name: t for t in plan.topics}
    assert topics["/cmd_vel"].msgtype == "geometry_msgs/msg/Twist"
    assert [f.paths for f in topics["/cmd_vel"].fields] == [("linear.x",), ("angular.z",)]
    assert topics["/cmd_vel"].publisher == "tracker"
    assert topics["/odom"].msgtype == "nav_msgs/msg/Odometry"
    assert topics["/world/front"].msgtype == "sensor_msgs/msg/Image"
    assert topics["/detector/blobX"].msgtype == "std_msgs/msg/Float64MultiArray"
    assert topics["/odometry/theta"].msgtype == "std_msgs/msg/Float64"
    assert topics["/cmd_vel"].qos == PROFILES["default"]
    assert plan.node("world").subscribes == ("/cmd_vel",)
    assert set(plan.node("tracker").publishes) == {"/cmd_vel"}


def test_paper_names_from_the_ros2_section():
    system = make_system(
        Ros2Spec(
            nodes={"odometry": "fmu_odometry_node", "tracker": "fmu_sign_tracking_node"},
            topics={
                "world.front": "/camera/image_raw",
                "odometry.posX": TopicSpec(topic="/fmu_odom_out", field="data"),
                "detector.blobX": "/onnx_blobX",
                "tracker.v": "/cmd_vel.linear.x",
                "tracker.w": "/cmd_vel.angular.z",
            },
            qos={"/camera/image_raw": "sensor_data"},
        )
    )
    plan, diagnostics = build_plan(system)
    assert diagnostics == []
    assert plan is not None
    assert plan.node("odometry").fqn == "/fmu_odometry_node"
    assert plan.topic("/camera/image_raw").qos == PROFILES["sensor_data"]
    assert plan.topic_of("detector", "blobX").name == "/onnx_blobX"


def test_namespace_prefixes_relative_default_topics():
    plan, _ = build_plan(make_system(Ros2Spec(namespace="/robot1")))
    assert plan is not None
    assert {"/robot1/cmd_vel", "/robot1/odom"} <= {t.name for t in plan.topics}


def test_external_world_gets_no_node_and_its_topics_come_from_outside():
    plan, diagnostics = build_plan(make_system(world_external=True))
    assert diagnostics == []
    assert plan is not None
    assert "world" not in {n.component for n in plan.nodes}
    assert plan.topic("/odom").publisher is None
    assert plan.external == ("world",)


def _codes(ros2: Ros2Spec) -> list[tuple[str, str]]:
    return [(d.code, d.message) for d in check_ros2(make_system(ros2))]


@pytest.mark.parametrize(
    ("ros2", "code", "text"),
    [
        (
            Ros2Spec(topics={"tracker.v": TopicSpec(topic="/v", type="geometry_msgs/msg/Twst")}),
            "E060",
            "unknown ROS 2 message type",
        ),
        (Ros2Spec(topics={"tracker.v": "/cmd_vel.linear.q"}), "E061", "has no member `q`"),
        (
            Ros2Spec(topics={"tracker.v": TopicSpec(topic="/v", type="std_msgs/msg/String")}),
            "E061",
            "holds `string`",
        ),
        (
            Ros2Spec(topics={"detector.blobX": TopicSpec(topic="/b", type="std_msgs/msg/Float64")}),
            "E061",
            "has 3 elements",
        ),
        (
            Ros2Spec(
                topics={
                    "world.base_pos": TopicSpec(
                        topic="/p", type="geometry_msgs/msg/Quaternion", field=""
                    )
                }
            ),
            "E061",
            "without a field",
        ),
        (Ros2Spec(topics={"tracker.v": "/cmd-vel"}), "E062", "only letters"),
        (Ros2Spec(nodes={"tracker": "9tracker"}), "E062", "must not start with a digit"),
        (Ros2Spec(nodes={"tracker": "odometry"}), "E062", "is used by"),
        (Ros2Spec(namespace="robot"), "E062", "must be absolute"),
        (Ros2Spec(qos={"/cmd_vel": "fast"}), "E063", "unknown QoS profile"),
        (
            Ros2Spec(
                topics={"tracker.v": TopicSpec(topic="/cmd_vel.linear.x", qos="sensor_data")},
                qos={"tracker.v": QosSpec(depth=3)},
            ),
            "E063",
            "two different QoS profiles",
        ),
        (
            Ros2Spec(topics={"tracker.stopRobot": "/shared", "odometry.theta": "/shared"}),
            "E064",
            "published by both",
        ),
        (Ros2Spec(topics={"odometry.qw": "/qw"}), "E064", "is an input driven by"),
        (Ros2Spec(nodes={"trackr": "x"}), "E065", "component `trackr`"),
        (Ros2Spec(topics={"tracker.vv": "/v"}), "E065", "has no port `vv`"),
        (Ros2Spec(qos={"/nothing": "default"}), "E065", "no port is mapped onto"),
    ],
    ids=lambda v: v if isinstance(v, str) else None,
)
def test_ros2_section_errors_have_codes(ros2, code, text):
    found = _codes(ros2)
    assert any(c == code and text in m for c, m in found), found


def test_did_you_mean_for_a_misspelt_message_type():
    [diagnostic] = check_ros2(
        make_system(
            Ros2Spec(topics={"tracker.v": TopicSpec(topic="/v", type="geometry_msgs/msg/Twst")})
        )
    )
    assert diagnostic.hint == "did you mean `geometry_msgs/msg/Twist`?"


def test_ros1_style_type_names_are_accepted():
    system = make_system(
        Ros2Spec(topics={"tracker.v": TopicSpec(topic="/v", type="std_msgs/Float64")})
    )
    assert check_ros2(system) == []


def test_mujoco_quaternion_onto_a_whole_orientation_message_fills_members_by_name() -> None:
    spec = Ros2Spec(
        topics={
            "world.base_quat": TopicSpec(
                topic="/odom", type="nav_msgs/msg/Odometry", field="pose.pose.orientation"
            )
        }
    )
    plan, diagnostics = build_plan(make_system(spec))
    assert diagnostics == []
    assert plan is not None
    # MuJoCo's w, x, y, z go to the members of those names, not in ROS's x, y, z, w order
    assert plan.topic("/odom").field_of("base_quat").paths == tuple(
        f"pose.pose.orientation.{axis}" for axis in "wxyz"
    )


def test_ros2_topics_name_dotted_and_quoted_ports_as_connections_do() -> None:
    """`ros2.topics` keys were split at their last dot: a dotted port (`body.x`, Modelica) was
    read as component `tracker.body`, and a port named `input.1` could not be named at all."""
    import dataclasses

    from fmionnx.compile.ros2.settings import ros2_settings
    from fmionnx.core.types import Causality, DType, Port

    system = make_system()
    tracker = system.component("tracker")
    extra = (
        Port("body.x", Causality.OUTPUT, DType.FLOAT64, ()),
        Port("12", Causality.OUTPUT, DType.FLOAT64, ()),
    )
    interface = dataclasses.replace(tracker.interface, ports=(*tracker.interface.ports, *extra))
    components = tuple(
        dataclasses.replace(c, interface=interface) if c.name == "tracker" else c
        for c in system.components
    )
    ros2 = Ros2Spec(topics={"tracker.body.x": "/body_x", 'tracker."12"': "/twelve"})
    system = dataclasses.replace(system, components=components, ros2=ros2_settings(ros2))
    plan, diagnostics = build_plan(system)
    assert [d.message for d in diagnostics if d.code.startswith("E")] == []
    assert plan is not None
    assert plan.topic("/body_x").publisher is not None
    assert plan.topic("/twelve").publisher is not None
