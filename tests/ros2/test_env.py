"""Domain and Cyclone configuration derived from the ROS 2 environment, per distribution."""

from __future__ import annotations

import pytest

from fmionnx.backends.ros2.env import DiscoveryRange, Ros2EnvError, from_environment
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.names import (
    dds_topic,
    expand_topic,
    namespace_problem,
    node_name_problem,
    ros_topic,
    sanitize_token,
    topic_problem,
)


def test_humble_localhost_only_pins_the_loopback_interface():
    env = from_environment(RosDistro.HUMBLE, {"ROS_DOMAIN_ID": "7", "ROS_LOCALHOST_ONLY": "1"})
    assert env.domain_id == 7
    assert '<NetworkInterface address="127.0.0.1"/>' in env.cyclone_config()


def test_humble_localhost_only_keeps_multicast_for_discovery_only():
    # data by multicast lets a /clock tick overtake a camera frame (benchmarks/ros2_pipeline.py)
    env = from_environment(RosDistro.HUMBLE, {"ROS_LOCALHOST_ONLY": "1"})
    assert "<AllowMulticast>spdp</AllowMulticast>" in env.cyclone_config()


def test_humble_without_variables_uses_cyclone_defaults():
    env = from_environment(RosDistro.HUMBLE, {})
    assert (env.domain_id, env.cyclone_config()) == (0, "")


def test_jazzy_localhost_range_uses_unicast_to_localhost():
    env = from_environment(RosDistro.JAZZY, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    config = env.cyclone_config()
    assert "<AllowMulticast>false</AllowMulticast>" in config
    assert '<Peer address="localhost"/>' in config


def test_jazzy_localhost_range_selects_loopback_so_fast_dds_peers_can_answer():
    env = from_environment(RosDistro.JAZZY, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert '<NetworkInterface address="127.0.0.1"/>' in env.cyclone_config()
    with_peers = from_environment(
        RosDistro.JAZZY,
        {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": "10.0.0.2"},
    )
    assert "NetworkInterface" not in with_peers.cyclone_config()


def test_jazzy_honours_the_deprecated_localhost_only_variable():
    env = from_environment(
        RosDistro.JAZZY, {"ROS_LOCALHOST_ONLY": "1", "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
    )
    assert env.discovery is DiscoveryRange.LOCALHOST


def test_jazzy_static_peers_become_cyclone_peers():
    env = from_environment(RosDistro.JAZZY, {"ROS_STATIC_PEERS": "10.0.0.2; robot.local"})
    config = env.cyclone_config()
    assert '<Peer address="10.0.0.2"/>' in config
    assert '<Peer address="robot.local"/>' in config
    assert "AllowMulticast" not in config


def test_cyclonedds_uri_is_appended_last_so_it_wins():
    env = from_environment(
        RosDistro.HUMBLE, {"ROS_LOCALHOST_ONLY": "1", "CYCLONEDDS_URI": "file://my.xml"}
    )
    assert env.cyclone_config().endswith(",file://my.xml")


@pytest.mark.parametrize("value", ["abc", "-1", "300"])
def test_bad_domain_id_is_refused_with_the_variable_named(value):
    with pytest.raises(Ros2EnvError, match="ROS_DOMAIN_ID"):
        from_environment(RosDistro.HUMBLE, {"ROS_DOMAIN_ID": value})


def test_bad_discovery_range_is_refused():
    with pytest.raises(Ros2EnvError, match="ROS_AUTOMATIC_DISCOVERY_RANGE='LAN'"):
        from_environment(RosDistro.JAZZY, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LAN"})


def test_topic_names_map_onto_rt_prefixed_dds_topics():
    assert dds_topic("/cmd_vel") == "rt/cmd_vel"
    assert ros_topic("rt/camera/image_raw") == "/camera/image_raw"
    assert ros_topic("ros_discovery_info") is None


def test_relative_and_private_names_expand_in_the_namespace():
    assert expand_topic("cmd_vel", "/robot1") == "/robot1/cmd_vel"
    assert expand_topic("/odom", "/robot1") == "/odom"
    assert expand_topic("~/out", "/", "tracker") == "/tracker/out"


@pytest.mark.parametrize("name", ["/a//b", "/a/", "/1abc", "/a b", "/cmd-vel"])
def test_invalid_topic_names_are_explained(name):
    assert topic_problem(name) is not None


def test_node_and_namespace_rules():
    assert node_name_problem("fmu_odometry_node") is None
    assert node_name_problem("9lives") is not None
    assert node_name_problem("a-b") is not None
    assert namespace_problem("/robot1") is None
    assert namespace_problem("robot1") is not None
    assert sanitize_token("base_quat[0]") == "base_quat_0"
