"""The live ROS 2 graph of a Zenoh domain, as ``ros2 node list`` reads it under rmw_zenoh.

rmw_zenoh has no discovery topic: every node and endpoint is a liveliness token, so the graph
is the set of tokens alive under ``@ros2_lv/<domain>/``. This module opens a session without
tokens of its own (it is an observer, not a node), collects the tokens for a while and builds
the same :class:`~fmionnx.backends.ros2.graph.LiveGraph` as DDS discovery does, so that the
comparison with the plan and both reports are shared. Nodes of other ROS 2 systems on the same
router (rclpy or rclcpp on rmw_zenoh) appear like fmionnx's own.
"""

from __future__ import annotations

import time
from typing import Any

from fmionnx.backends.ros2.graph import UNKNOWN_TYPE, LiveGraph
from fmionnx.backends.ros2.zenoh.config import ZenohConfigError, ZenohEnvironment
from fmionnx.backends.ros2.zenoh.graph_cache import GraphCache
from fmionnx.backends.ros2.zenoh.keys import EntityKind, ParsedToken

_LINK_KIND = {EntityKind.PUBLISHER: "pub", EntityKind.SUBSCRIPTION: "sub"}


def graph_of(tokens: list[ParsedToken]) -> LiveGraph:
    """Nodes, topics with their types, and (node, pub|sub, topic) links of ``tokens``."""
    graph = LiveGraph()
    for token in tokens:
        graph.nodes.add(token.fqn)
        kind = _LINK_KIND.get(token.kind)
        if kind is None or token.topic is None:
            continue
        msgtype = token.msgtype or UNKNOWN_TYPE
        link = (token.fqn, kind, token.topic)
        graph.topics.setdefault(token.topic, set()).add(msgtype)
        graph.links.add(link)
        graph.link_types.setdefault(link, set()).add(msgtype)  # each endpoint's own type
    return graph


def read_zenoh_graph(env: ZenohEnvironment, timeout: float) -> LiveGraph:
    """Listen to the liveliness space of ``env``'s domain for ``timeout`` seconds."""
    import zenoh

    try:
        session: Any = zenoh.open(env.config())
    except zenoh.ZError as exc:
        msg = f"cannot open a Zenoh session: {exc}"
        raise ZenohConfigError(msg) from None
    try:
        cache = GraphCache(session, env.domain_id)
        time.sleep(timeout)
        tokens = cache.snapshot()
        cache.close()
    finally:
        session.close()
    return graph_of(tokens)
