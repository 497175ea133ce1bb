"""The live ROS 2 graph from DDS discovery, compared with a compiled system's plan.

What ``ros2 node list`` / ``ros2 topic info -v`` / rqt_graph show, read the way they read it:
DDS built-in topics (``DCPSPublication``/``DCPSSubscription``: every writer and reader with its
topic and type) joined with ``ros_discovery_info`` (which node owns which endpoint GUID). An
endpoint that no node claims belongs to a plain DDS participant and is shown as such.

The comparison works on *links*: ``(node, "pub"|"sub", topic)``. A link of the plan that is not
live is *missing*; a live link on a topic of the plan that the plan does not have is *extra*
(a foreign subscriber of ``/cmd_vel``, a second publisher). A live link of the plan whose
endpoint has another message type than the plan's is of the *wrong type*, not ok: DDS matches
a writer and a reader only when their type names agree (a node of an older fmionnx publishing
an ``int64`` port as ``std_msgs/msg/Float64`` reaches no ``std_msgs/msg/Int64`` reader).
Control topics (``/clock``, ``/fmionnx/...``) and ``ros_discovery_info`` are listed but never
compared.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState

from fmionnx.backends.ros2.discovery import GraphListener
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.names import ros_topic
from fmionnx.compile.ros2.types import Ros2Plan

Link = tuple[str, str, str]  # (node, "pub" | "sub", topic)

#: The type shown for an endpoint whose type a source could not name; never compared.
UNKNOWN_TYPE = "?"

#: Topics of the run's machinery, shown but not compared with the plan.
CONTROL_PREFIXES = ("/clock", "/fmionnx/", "/rosout", "/parameter_events")


def ros_type(dds_type: str) -> str:
    """``geometry_msgs::msg::dds_::Twist_`` -> ``geometry_msgs/msg/Twist``."""
    parts = dds_type.split("::")
    if len(parts) == 4 and parts[2] == "dds_" and parts[3].endswith("_"):
        return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
    return dds_type


@dataclass
class LiveGraph:
    """Nodes, topics and links seen on the domain."""

    nodes: set[str] = field(default_factory=set)
    participants: dict[str, str] = field(default_factory=dict)  # endpoint-less node label
    topics: dict[str, set[str]] = field(default_factory=dict)  # ROS topic -> types
    links: set[Link] = field(default_factory=set)
    #: The types of each link's own endpoints; a link without an entry (a graph built from
    #: another source) is judged by its topic's types.
    link_types: dict[Link, set[str]] = field(default_factory=dict)

    def types_of(self, link: Link) -> set[str]:
        """The message types ``link``'s endpoints use (else every type seen on its topic);
        ``?`` (a type a source could not name) is left out."""
        return (self.link_types.get(link) or self.topics.get(link[2], set())) - {UNKNOWN_TYPE}

    def publishers(self, topic: str) -> list[str]:
        """Nodes writing ``topic``."""
        return sorted(n for n, kind, t in self.links if t == topic and kind == "pub")

    def subscribers(self, topic: str) -> list[str]:
        """Nodes reading ``topic``."""
        return sorted(n for n, kind, t in self.links if t == topic and kind == "sub")


def _alive(reader: BuiltinDataReader) -> list[Any]:
    condition = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Alive)
    return list(reader.read(N=4096, condition=condition))


def read_live_graph(participant: Participant, timeout: float) -> LiveGraph:
    """Listen to discovery for ``timeout`` seconds and build the live graph."""
    listener = GraphListener(participant)
    dp = participant.dp
    publications = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    subscriptions = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    participants = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        listener.poll()
        time.sleep(0.05)
    listener.poll()
    owner: dict[bytes, str] = {}
    graph = LiveGraph()
    for entities in listener.nodes():
        graph.nodes.add(entities.fqn)
        for gid in (*entities.readers, *entities.writers):
            owner[gid] = entities.fqn
    own = participant.gid
    for kind, reader in (("pub", publications), ("sub", subscriptions)):
        for endpoint in _alive(reader):
            if endpoint.participant_key.bytes == own:
                continue
            topic = ros_topic(endpoint.topic_name)
            if topic is None:
                continue
            node = owner.get(endpoint.key.bytes)
            if node is None:
                node = f"(participant {endpoint.participant_key.hex[:8]})"
                graph.participants[node] = endpoint.participant_key.hex
            msgtype = ros_type(endpoint.type_name)
            graph.topics.setdefault(topic, set()).add(msgtype)
            graph.links.add((node, kind, topic))
            graph.link_types.setdefault((node, kind, topic), set()).add(msgtype)
    _alive(participants)  # keeps the reader's cache fresh; participants show through endpoints
    return graph


def plan_links(plan: Ros2Plan) -> set[Link]:
    """The links the plan expects."""
    links: set[Link] = set()
    for node in plan.nodes:
        links.update((node.fqn, "pub", t) for t in node.publishes)
        links.update((node.fqn, "sub", t) for t in node.subscribes)
    return links


@dataclass(frozen=True)
class WrongType:
    """A live link of the plan whose endpoint uses another message type than the plan's."""

    link: Link
    expected: str
    seen: tuple[str, ...]


@dataclass(frozen=True)
class Comparison:
    """Plan links found live, missing, live links on plan topics that the plan lacks, and
    plan links live with another message type (they match no endpoint of the plan's type)."""

    ok: tuple[Link, ...]
    missing: tuple[Link, ...]
    extra: tuple[Link, ...]
    wrong_type: tuple[WrongType, ...] = ()

    @property
    def complete(self) -> bool:
        """Every link of the plan is live with the plan's type (``ros2 graph`` exits 0)."""
        return not self.missing and not self.wrong_type


def compare(plan: Ros2Plan, graph: LiveGraph) -> Comparison:
    """Compare the live graph with the plan (control topics are left out)."""
    expected = plan_links(plan)
    types = {t.name: t.msgtype for t in plan.topics}
    live = {link for link in graph.links if not link[2].startswith(CONTROL_PREFIXES)}
    extra = {link for link in live - expected if link[2] in types}
    wrong = [
        WrongType(link, types[link[2]], tuple(sorted(seen)))
        for link in sorted(expected & live)
        if (seen := graph.types_of(link)) and types[link[2]] not in seen
    ]
    ok = (expected & live) - {w.link for w in wrong}
    return Comparison(
        tuple(sorted(ok)), tuple(sorted(expected - live)), tuple(sorted(extra)), tuple(wrong)
    )


def render_text(plan: Ros2Plan, graph: LiveGraph, result: Comparison) -> str:
    """The report ``fmionnx ros2 graph`` prints."""
    planned = {n.fqn: n.component for n in plan.nodes}
    lines = ["nodes:"]
    for node in sorted(graph.nodes | set(graph.participants)):
        where = f"component `{planned[node]}`" if node in planned else "not in the system"
        lines.append(f"  {node:<36} {where}")
    for node in sorted(set(planned) - graph.nodes):
        lines.append(f"  {node:<36} MISSING (component `{planned[node]}`)")
    lines.append("topics:")
    for topic in sorted(graph.topics):
        types = ", ".join(sorted(graph.topics[topic]))
        lines.append(f"  {topic}  [{types}]")
        lines.append(f"    publishers:  {', '.join(graph.publishers(topic)) or '-'}")
        lines.append(f"    subscribers: {', '.join(graph.subscribers(topic)) or '-'}")
    lines.append("compared with the system:")
    arrow = {"pub": "->", "sub": "<-"}
    for label, links in (("ok", result.ok), ("missing", result.missing), ("extra", result.extra)):
        for node, kind, topic in links:
            lines.append(f"  {label:<8} {node} {arrow[kind]} {topic}")
    for wrong in result.wrong_type:
        node, kind, topic = wrong.link
        lines.append(
            f"  {'type':<8} {node} {arrow[kind]} {topic}  "
            f"seen {', '.join(wrong.seen)}, expected {wrong.expected}"
        )
    summary = (
        f"{len(result.ok)} link(s) ok, {len(result.missing)} missing, {len(result.extra)} extra"
    )
    if result.wrong_type:
        summary += f", {len(result.wrong_type)} of the wrong type"
    lines.append(summary)
    return "\n".join(lines) + "\n"


def render_json(plan: Ros2Plan, graph: LiveGraph, result: Comparison) -> str:
    """The same report as JSON (stable keys)."""

    def links(items: tuple[Link, ...]) -> list[dict[str, str]]:
        return [{"node": n, "kind": k, "topic": t} for n, k, t in items]

    document = {
        "nodes": sorted(graph.nodes | set(graph.participants)),
        "planned_nodes": {n.fqn: n.component for n in plan.nodes},
        "topics": {
            topic: {
                "types": sorted(graph.topics[topic]),
                "publishers": graph.publishers(topic),
                "subscribers": graph.subscribers(topic),
            }
            for topic in sorted(graph.topics)
        },
        "ok": links(result.ok),
        "missing": links(result.missing),
        "extra": links(result.extra),
        "wrong_type": [
            {
                "node": w.link[0],
                "kind": w.link[1],
                "topic": w.link[2],
                "expected": w.expected,
                "seen": list(w.seen),
            }
            for w in result.wrong_type
        ],
    }
    return json.dumps(document, indent=2) + "\n"
