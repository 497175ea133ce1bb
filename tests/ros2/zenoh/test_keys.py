"""The rmw_zenoh wire's names and bytes, checked against the published facts (no session)."""

from __future__ import annotations

import struct

import pytest
import xxhash

from fmionnx.backends.ros2.env import Ros2EnvError
from fmionnx.backends.ros2.zenoh import attachment
from fmionnx.backends.ros2.zenoh.config import (
    ZenohConfigError,
    parse_overrides,
    zenoh_environment,
)
from fmionnx.backends.ros2.zenoh.keys import (
    EntityKind,
    NodeToken,
    gid_of,
    parse_qos,
    parse_token,
    qos_segment,
    topic_key,
    type_hash,
)
from fmionnx.backends.ros2.zenoh.router import router_problem, tcp_address
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES, Durability, QosProfile, Reliability

TWIST_HASH = "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"


@pytest.mark.parametrize("distro", [RosDistro.JAZZY, RosDistro.KILTED])
def test_topic_key_has_the_dds_type_and_the_rihs01_hash(distro: RosDistro) -> None:
    assert topic_key(0, "/cmd_vel", "geometry_msgs/msg/Twist", distro) == (
        f"0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{TWIST_HASH}"
    )
    assert topic_key(7, "/robot/camera/image_raw", "sensor_msgs/msg/Image", distro).startswith(
        "7/robot/camera/image_raw/sensor_msgs::msg::dds_::Image_/RIHS01_"
    )


def test_humble_keys_say_type_hash_not_supported() -> None:
    assert type_hash("geometry_msgs/msg/Twist", RosDistro.HUMBLE) == "TypeHashNotSupported"
    assert topic_key(0, "/cmd_vel", "geometry_msgs/msg/Twist", RosDistro.HUMBLE).endswith(
        "/geometry_msgs::msg::dds_::Twist_/TypeHashNotSupported"
    )


def test_node_token_matches_the_documented_example() -> None:
    node = NodeToken(0, "2f8339df3dcf70de2c84290d83cfed1b", 0, "/", "tracker_node")
    assert node.node() == "@ros2_lv/0/2f8339df3dcf70de2c84290d83cfed1b/0/0/NN/%/%/tracker_node"


def test_entity_token_mangles_the_topic_and_encodes_qos_and_reads_back() -> None:
    node = NodeToken(3, "ab12", 0, "/robot", "fmu_sign_tracking_node")
    key = node.entity(
        4, EntityKind.PUBLISHER, "/robot/cmd_vel", "geometry_msgs/msg/Twist",
        PROFILES["default"], RosDistro.JAZZY,
    )  # fmt: skip
    assert key == (
        "@ros2_lv/3/ab12/0/4/MP/%/%robot/fmu_sign_tracking_node/%robot%cmd_vel/"
        f"geometry_msgs::msg::dds_::Twist_/{TWIST_HASH}/::,10:,:,:,,"
    )
    parsed = parse_token(key)
    assert parsed is not None
    assert (parsed.fqn, parsed.kind, parsed.topic) == (
        "/robot/fmu_sign_tracking_node", EntityKind.PUBLISHER, "/robot/cmd_vel",
    )  # fmt: skip
    assert parsed.msgtype == "geometry_msgs/msg/Twist"
    assert parsed.qos == PROFILES["default"]
    assert parse_token("@ros2_lv/0/x/NN") is None
    assert parse_token("0/cmd_vel/some/hash") is None


@pytest.mark.parametrize(
    ("profile", "segment"),
    [
        (QosProfile(), "::,10:,:,:,,"),
        (PROFILES["sensor_data"], "2::,5:,:,:,,"),
        (QosProfile(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1), ":1:,1:,:,:,,"),
        (QosProfile(depth=42), "::,:,:,:,,"),
        (QosProfile(depth=64, keep_all=True), "::2,64:,:,:,,"),
    ],
)
def test_qos_segment_leaves_rmw_zenoh_defaults_empty(profile: QosProfile, segment: str) -> None:
    assert qos_segment(profile) == segment
    assert parse_qos(segment) == profile


def test_gid_is_the_xxh3_128_of_the_token_low_half_first() -> None:
    token = "@ros2_lv/0/ab/0/1/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/h/::,10:,:,:,,"
    value = xxhash.xxh3_128_intdigest(token.encode())
    expected = struct.pack("<QQ", value & (2**64 - 1), value >> 64)
    assert gid_of(token) == expected
    assert len(gid_of(token)) == 16


def test_attachment_is_33_bytes_sequence_time_length_gid() -> None:
    gid = bytes(range(16))
    data = attachment.encode(1, 1_700_000_000_123_456_789, gid)
    assert len(data) == attachment.SIZE == 33
    assert data[:8] == (1).to_bytes(8, "little")
    assert data[8:16] == (1_700_000_000_123_456_789).to_bytes(8, "little")
    assert data[16] == 0x10
    assert data[17:] == gid
    decoded = attachment.decode(data)
    assert (decoded.sequence, decoded.timestamp_ns, decoded.gid) == (
        1,
        1_700_000_000_123_456_789,
        gid,
    )
    with pytest.raises(attachment.AttachmentError):
        attachment.decode(data[:20])


def test_environment_reads_domain_config_file_and_overrides(tmp_path) -> None:
    config = tmp_path / "zenoh.json5"
    config.write_text('{mode: "peer", connect: {endpoints: ["tcp/127.0.0.1:7999"]}}')
    env = zenoh_environment(
        RosDistro.JAZZY,
        {"ROS_DOMAIN_ID": "12", "ZENOH_SESSION_CONFIG_URI": str(config)},
    )
    assert env.domain_id == 12
    assert env.endpoints() == ["tcp/127.0.0.1:7999"]
    env = zenoh_environment(
        RosDistro.JAZZY,
        {"ZENOH_CONFIG_OVERRIDE": 'connect/endpoints=["tcp/127.0.0.1:7001","tcp/h:2"];'
                                  "scouting/multicast/enabled=false"},
    )  # fmt: skip
    assert env.endpoints() == ["tcp/127.0.0.1:7001", "tcp/h:2"]
    assert zenoh_environment(RosDistro.JAZZY, {}).endpoints() == ["tcp/localhost:7447"]
    assert env.with_router("tcp/127.0.0.1:9").endpoints() == ["tcp/127.0.0.1:9"]


def test_sessions_listen_on_loopback_only_unless_configured_otherwise(tmp_path) -> None:
    # rmw_zenoh's default session config: peers accept connections from this host only; the
    # router carries traffic between hosts. Zenoh's own default would be `tcp/[::]:0`.
    assert zenoh_environment(RosDistro.JAZZY, {}).listen_endpoints() == ["tcp/localhost:0"]
    routed = zenoh_environment(RosDistro.JAZZY, {}).with_router("tcp/10.0.0.2:7447")
    assert routed.listen_endpoints() == ["tcp/localhost:0"]
    override = zenoh_environment(
        RosDistro.JAZZY, {"ZENOH_CONFIG_OVERRIDE": 'listen/endpoints=["tcp/[::]:0"]'}
    )
    assert override.listen_endpoints() == ["tcp/[::]:0"]
    config = tmp_path / "zenoh.json5"
    config.write_text('{mode: "peer", listen: {endpoints: ["tcp/0.0.0.0:7500"]}}')
    from_file = zenoh_environment(RosDistro.JAZZY, {"ZENOH_SESSION_CONFIG_URI": str(config)})
    assert from_file.listen_endpoints() == ["tcp/0.0.0.0:7500"]


@pytest.mark.parametrize(
    ("environ", "message"),
    [
        ({"ZENOH_SESSION_CONFIG_URI": "no/such.json5"}, "no such file"),
        ({"ZENOH_CONFIG_OVERRIDE": "mode"}, "must look like `key=value`"),
        ({"ROS_DOMAIN_ID": "x"}, "not a whole number"),
    ],
)
def test_bad_environment_is_a_clear_error(environ: dict[str, str], message: str) -> None:
    with pytest.raises(Ros2EnvError, match=message):
        zenoh_environment(RosDistro.JAZZY, environ)


def test_unknown_override_key_is_named_when_the_config_is_built() -> None:
    env = zenoh_environment(RosDistro.JAZZY, {"ZENOH_CONFIG_OVERRIDE": "no/such/key=1"})
    with pytest.raises(ZenohConfigError, match="`no/such/key=1`: unknown key"):
        env.config()


def test_override_values_may_hold_semicolons_in_brackets_and_quotes() -> None:
    assert parse_overrides('a=["x;y"];b=1') == (("a", '["x;y"]'), ("b", "1"))


def test_router_values() -> None:
    assert router_problem("auto") is None
    assert router_problem("tcp/localhost:7447") is None
    assert router_problem("localhost:7447") is not None
    assert tcp_address("tcp/[::1]:7447") == ("::1", 7447)
    assert tcp_address("udp/h:1") is None


def test_liveliness_tokens_make_the_live_graph_that_is_compared_with_the_plan() -> None:
    from fmionnx.backends.ros2.graph import compare, render_text
    from fmionnx.backends.ros2.loading import plan_for
    from fmionnx.backends.ros2.zenoh.graph import graph_of
    from tests.ros2.conftest import make_system

    plan = plan_for(make_system(), RosDistro.JAZZY)
    tokens = []
    for index, node in enumerate(plan.nodes):
        owner = NodeToken(0, f"{index:032x}", 0, node.namespace, node.name)
        tokens.append(owner.node())
        for kind, topics in ((EntityKind.PUBLISHER, node.publishes),
                             (EntityKind.SUBSCRIPTION, node.subscribes)):  # fmt: skip
            for number, topic in enumerate(topics, 1):
                msgtype = plan.topic(topic).msgtype
                tokens.append(
                    owner.entity(number, kind, topic, msgtype, QosProfile(), RosDistro.JAZZY)
                )
    foreign = NodeToken(0, "f" * 32, 0, "/", "teleop_listener")
    tokens += [foreign.node(), foreign.entity(
        1, EntityKind.SUBSCRIPTION, "/cmd_vel", "geometry_msgs/msg/Twist", QosProfile(),
        RosDistro.JAZZY,
    )]  # fmt: skip
    parsed = [parse_token(t) for t in tokens]
    graph = graph_of([p for p in parsed if p is not None])
    result = compare(plan, graph)
    assert result.missing == ()
    assert result.extra == (("/teleop_listener", "sub", "/cmd_vel"),)
    assert graph.topics["/cmd_vel"] == {"geometry_msgs/msg/Twist"}
    text = render_text(plan, graph, result)
    assert "/teleop_listener" in text
    assert "not in the system" in text


def test_a_zenoh_endpoint_of_another_type_is_told_apart_on_a_shared_topic() -> None:
    """Each liveliness token carries its endpoint's type: a publisher of the wrong type is
    reported although a subscriber of the right type shares the topic (compared per topic,
    the right subscriber's type hid it)."""
    from fmionnx.backends.ros2.graph import compare
    from fmionnx.backends.ros2.loading import plan_for
    from fmionnx.backends.ros2.zenoh.graph import graph_of
    from tests.ros2.conftest import make_system

    plan = plan_for(make_system(), RosDistro.JAZZY)
    tokens = []
    wrong_link = None
    for index, node in enumerate(plan.nodes):
        owner = NodeToken(0, f"{index:032x}", 0, node.namespace, node.name)
        tokens.append(owner.node())
        for kind, topics in ((EntityKind.PUBLISHER, node.publishes),
                             (EntityKind.SUBSCRIPTION, node.subscribes)):  # fmt: skip
            for number, topic in enumerate(topics, 1):
                msgtype = plan.topic(topic).msgtype
                if (
                    wrong_link is None
                    and kind is EntityKind.PUBLISHER
                    and any(topic in other.subscribes for other in plan.nodes)
                ):
                    wrong_link, msgtype = (node.fqn, "pub", topic), "std_msgs/msg/String"
                tokens.append(
                    owner.entity(number, kind, topic, msgtype, QosProfile(), RosDistro.JAZZY)
                )
    assert wrong_link is not None  # the system has a topic both published and subscribed
    parsed = [parse_token(t) for t in tokens]
    result = compare(plan, graph_of([p for p in parsed if p is not None]))
    assert [w.link for w in result.wrong_type] == [wrong_link]
    assert wrong_link not in result.ok
