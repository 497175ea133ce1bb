"""Message definitions, field paths and CDR bytes, checked against cyclonedds' own serialiser."""

# No `from __future__ import annotations`: cyclonedds resolves member types at class creation.
from dataclasses import dataclass

import numpy as np
import pytest
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as t
from cyclonedds.idl.annotations import final

from fmionnx.backends.ros2.codec import WHOLE, PortField, TopicCodec
from fmionnx.backends.ros2.discovery import NodeEntities, decode_info, encode_info, gid_size
from fmionnx.backends.ros2.idl import dds_type_name, idl_type, ros_type_name
from fmionnx.compile.ros2.messages import (
    FieldError,
    FieldKind,
    RosDistro,
    default_message,
    resolve_field,
    serialize,
)


# Hand-written as ROS 2's generated IDL declares them: an independent implementation.
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


def test_twist_bytes_equal_an_independent_cyclonedds_type():
    codec = TopicCodec(
        "geometry_msgs/msg/Twist",
        (PortField("v", ("linear.x",)), PortField("w", ("angular.z",))),
        RosDistro.HUMBLE,
    )
    ours = codec.encode({"v": np.array(0.3), "w": np.array(-0.8)})
    theirs = Twist_(Vector3_(0.3, 0.0, 0.0), Vector3_(0.0, 0.0, -0.8)).serialize()
    assert ours == theirs
    assert ours[:4] == b"\x00\x01\x00\x00"  # CDR little endian encapsulation


# (type, port fields, values): every message type the default mapping sends.
SENT = [
    ("std_msgs/msg/Float64", (PortField("y", ("data",)),), {"y": np.array(2.5)}),
    (
        "std_msgs/msg/Float64MultiArray",
        (PortField("b", ("data",), (1, 3)),),
        {"b": np.array([[1.0, -2.0, 3.5]])},
    ),
    ("std_msgs/msg/String", (PortField("s", ("data",), (), "string"),), {"s": np.array("hi")}),
    (
        "nav_msgs/msg/Odometry",
        (
            PortField("p", ("pose.pose.position",), (3,)),
            PortField("q", tuple(f"pose.pose.orientation.{a}" for a in "wxyz"), (4,)),
        ),
        {"p": np.array([1.0, 2.0, 0.05]), "q": np.array([0.7, 0.0, 0.0, 0.7])},
    ),
    (
        "sensor_msgs/msg/Image",
        (PortField("img", (WHOLE,), (4, 5, 3), "uint8"),),
        {"img": np.arange(60, dtype=np.uint8).reshape(4, 5, 3)},
    ),
    ("rosgraph_msgs/msg/Clock", (PortField("t", ("clock.sec",)),), {"t": np.array(3)}),
]


@pytest.mark.parametrize("distro", [RosDistro.HUMBLE, RosDistro.JAZZY])
@pytest.mark.parametrize(("msgtype", "fields", "values"), SENT, ids=[s[0] for s in SENT])
def test_sent_bytes_decode_and_reencode_identically_with_cyclonedds(
    distro, msgtype, fields, values
):
    codec = TopicCodec(msgtype, fields, distro, frame_id="cam")
    ours = codec.encode(values, stamp=12.25)
    sample = idl_type(msgtype, distro).deserialize(ours)
    assert sample.serialize() == ours
    decoded, stamp = codec.decode(ours)
    for port, value in values.items():
        if value.dtype.kind == "U":
            assert list(decoded[port]) == [str(value)]
            continue
        np.testing.assert_array_equal(decoded[port], np.asarray(value).reshape(-1))
    if hasattr(sample, "header"):
        assert (sample.header.stamp.sec, sample.header.stamp.nanosec) == (12, 250_000_000)
        assert stamp == 12.25


def test_odometry_orientation_lands_in_ros_field_order():
    codec = TopicCodec(
        "nav_msgs/msg/Odometry",
        (PortField("q", tuple(f"pose.pose.orientation.{a}" for a in "wxyz"), (4,)),),
        RosDistro.HUMBLE,
    )
    sample = idl_type("nav_msgs/msg/Odometry").deserialize(
        codec.encode({"q": np.array([1.0, 2.0, 3.0, 4.0])})
    )
    o = sample.pose.pose.orientation
    assert (o.x, o.y, o.z, o.w) == (2.0, 3.0, 4.0, 1.0)


def test_multiarray_layout_describes_the_port_shape():
    codec = TopicCodec(
        "std_msgs/msg/Float64MultiArray", (PortField("b", ("data",), (1, 3)),), RosDistro.HUMBLE
    )
    sample = idl_type("std_msgs/msg/Float64MultiArray").deserialize(
        codec.encode({"b": np.zeros((1, 3))})
    )
    assert [(d.size, d.stride) for d in sample.layout.dim] == [(1, 3), (3, 3)]


def test_full_size_rgb8_image_round_trips_bit_exact():
    rng = np.random.default_rng(1)
    frame = rng.integers(0, 256, (1, 480, 640, 3), dtype=np.uint8)
    codec = TopicCodec(
        "sensor_msgs/msg/Image",
        (PortField("img", (WHOLE,), (1, 480, 640, 3), "uint8"),),
        RosDistro.HUMBLE,
    )
    data = codec.encode({"img": frame}, stamp=0.1)
    assert len(data) == 4 + 4 + 4 + 4 + 4 + 4 + 4 + 5 + 3 + 1 + 3 + 4 + 4 + 640 * 480 * 3
    decoded, _ = codec.decode(data)
    np.testing.assert_array_equal(decoded["img"], frame.reshape(-1))


def test_bgr8_image_from_outside_arrives_as_rgb():
    rgb = np.arange(2 * 2 * 3, dtype=np.uint8).reshape(2, 2, 3)
    message = default_message("sensor_msgs/msg/Image")
    message.height, message.width, message.step, message.encoding = 2, 2, 6, "bgr8"
    message.data = rgb[:, :, ::-1].reshape(-1).copy()
    codec = TopicCodec(
        "sensor_msgs/msg/Image",
        (PortField("img", (WHOLE,), (2, 2, 3), "uint8"),),
        RosDistro.HUMBLE,
    )
    decoded, _ = codec.decode(serialize(message, "sensor_msgs/msg/Image"))
    np.testing.assert_array_equal(decoded["img"], rgb.reshape(-1))


def test_ros2_type_names_follow_the_dds_convention():
    assert dds_type_name("geometry_msgs/msg/Twist") == "geometry_msgs::msg::dds_::Twist_"
    assert ros_type_name("geometry_msgs::msg::dds_::Twist_") == "geometry_msgs/msg/Twist"
    assert ros_type_name("Twist") is None
    assert (
        idl_type("geometry_msgs/msg/Twist").__idl_typename__ == "geometry_msgs::msg::dds_::Twist_"
    )


def test_field_paths_resolve_to_scalars_sequences_and_messages():
    assert resolve_field("geometry_msgs/msg/Twist", "linear.x").kind is FieldKind.SCALAR
    assert resolve_field("std_msgs/msg/Float64MultiArray", "data").kind is FieldKind.SEQUENCE
    info = resolve_field("nav_msgs/msg/Odometry", "pose.pose.position")
    assert (info.kind, info.members) == (FieldKind.MESSAGE, ("x", "y", "z"))


def test_missing_field_lists_the_members_it_could_be():
    with pytest.raises(FieldError, match="`linear` has no member `q`") as caught:
        resolve_field("geometry_msgs/msg/Twist", "linear.q")
    assert caught.value.valid == ("x", "y", "z")


@pytest.mark.parametrize(("distro", "size"), [(RosDistro.HUMBLE, 24), (RosDistro.JAZZY, 16)])
def test_discovery_gid_size_follows_the_distribution(distro, size):
    assert gid_size(distro) == size
    guid = bytes(range(16))
    node = NodeEntities("/", "talker", readers=[bytes(16)], writers=[guid])
    data = encode_info(guid, [node], distro)
    sample = idl_type("rmw_dds_common/msg/ParticipantEntitiesInfo", distro).deserialize(data)
    assert len(sample.gid.data) == size
    assert sample.serialize() == data
    gid, nodes = decode_info(data, distro)
    assert gid == guid
    assert (nodes[0].fqn, nodes[0].writers) == ("/talker", [guid])
