"""Node discovery as ROS 2's middleware layer does it: the ``ros_discovery_info`` topic.

Nodes are not DDS entities. Every participant publishes a
``rmw_dds_common/msg/ParticipantEntitiesInfo`` sample (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1)
with its GID and, per node, namespace, name and the GIDs of the node's readers and writers;
``ros2 node list``, ``ros2 topic info -v`` and rqt_graph read it. A GID is the entity's 16-byte
DDS GUID; Humble's ``Gid`` holds 24 bytes (GUID + 8 zero bytes), Iron and later exactly 16.
The size is read from the distribution's message definition, never assumed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fmionnx.backends.ros2.transport import Participant, RawReader, RawWriter
from fmionnx.compile.ros2.messages import (
    RosDistro,
    default_message,
    deserialize,
    resolve_field,
    serialize,
    typestore,
)
from fmionnx.compile.ros2.qos import DISCOVERY_QOS, DISCOVERY_READER_QOS

#: DDS topic name: no ``rt`` prefix (the rmw layer creates it with
#: ``avoid_ros_namespace_conventions``).
DISCOVERY_TOPIC = "ros_discovery_info"
DISCOVERY_TYPE = "rmw_dds_common/msg/ParticipantEntitiesInfo"
_GID_TYPE = "rmw_dds_common/msg/Gid"
_NODE_TYPE = "rmw_dds_common/msg/NodeEntitiesInfo"


def gid_size(distro: RosDistro) -> int:
    """Bytes in a ``Gid`` of ``distro`` (24 for Humble, 16 from Iron on)."""
    return resolve_field(_GID_TYPE, "data", distro).length


def make_gid(guid: bytes, distro: RosDistro) -> Any:
    """A ``Gid`` message holding ``guid`` padded with zeros to the distribution's size."""
    size = gid_size(distro)
    data = np.zeros(size, dtype=np.uint8)
    data[: min(size, len(guid))] = np.frombuffer(guid[:size], dtype=np.uint8)
    return typestore(distro).types[_GID_TYPE](data=data)


def gid_bytes(gid: Any) -> bytes:
    """The 16 GUID bytes of a ``Gid`` message (padding dropped)."""
    return bytes(np.asarray(gid.data, dtype=np.uint8).tobytes()[:16])


@dataclass
class NodeEntities:
    """One node as announced: namespace, name, reader and writer GUIDs (16 bytes each)."""

    namespace: str
    name: str
    readers: list[bytes] = field(default_factory=list)
    writers: list[bytes] = field(default_factory=list)

    @property
    def fqn(self) -> str:
        """``/ns/name`` as ``ros2 node list`` prints it."""
        return self.namespace.rstrip("/") + "/" + self.name


def encode_info(participant_gid: bytes, nodes: list[NodeEntities], distro: RosDistro) -> bytes:
    """CDR bytes of one ``ParticipantEntitiesInfo`` sample."""
    store = typestore(distro)
    info = default_message(DISCOVERY_TYPE, distro)
    info.gid = make_gid(participant_gid, distro)
    info.node_entities_info_seq = [
        store.types[_NODE_TYPE](
            node_namespace=node.namespace or "/",
            node_name=node.name,
            reader_gid_seq=[make_gid(g, distro) for g in node.readers],
            writer_gid_seq=[make_gid(g, distro) for g in node.writers],
        )
        for node in nodes
    ]
    return serialize(info, DISCOVERY_TYPE, distro)


def decode_info(data: bytes, distro: RosDistro) -> tuple[bytes, list[NodeEntities]]:
    """Participant GUID and nodes of one ``ParticipantEntitiesInfo`` sample."""
    info = deserialize(data, DISCOVERY_TYPE, distro)
    nodes = [
        NodeEntities(
            namespace=n.node_namespace,
            name=n.node_name,
            readers=[gid_bytes(g) for g in n.reader_gid_seq],
            writers=[gid_bytes(g) for g in n.writer_gid_seq],
        )
        for n in info.node_entities_info_seq
    ]
    return gid_bytes(info.gid), nodes


class GraphAnnouncer:
    """Publishes this participant's nodes on ``ros_discovery_info`` (the rmw graph cache)."""

    def __init__(self, participant: Participant) -> None:
        self.participant = participant
        self.nodes: list[NodeEntities] = []
        self.writer: RawWriter = participant.writer(DISCOVERY_TOPIC, DISCOVERY_TYPE, DISCOVERY_QOS)

    def add_node(self, node: NodeEntities) -> None:
        """Announce one more node (and publish the updated participant sample)."""
        self.nodes.append(node)
        self.publish()

    def publish(self) -> None:
        """Publish the current state; TRANSIENT_LOCAL keeps it for late joiners."""
        distro = self.participant.distro
        self.writer.write(encode_info(self.participant.gid, self.nodes, distro))

    def withdraw(self) -> None:
        """Announce that this participant's nodes are gone (as ``rmw_destroy_node`` does)."""
        self.nodes.clear()
        self.publish()


class GraphListener:
    """Collects the latest ``ros_discovery_info`` sample of every participant."""

    def __init__(self, participant: Participant) -> None:
        self.participant = participant
        self.reader: RawReader = participant.reader(
            DISCOVERY_TOPIC, DISCOVERY_TYPE, DISCOVERY_READER_QOS
        )
        self.participants: dict[bytes, list[NodeEntities]] = {}

    def poll(self) -> None:
        """Fold every waiting sample into :attr:`participants` (own sample excluded)."""
        own = self.participant.gid
        for data in self.reader.take():
            gid, nodes = decode_info(data, self.participant.distro)
            if gid != own:
                self.participants[gid] = nodes

    def nodes(self) -> list[NodeEntities]:
        """Every node currently announced by another participant."""
        return [n for nodes in self.participants.values() for n in nodes]

    def wait_for(self, names: set[str], timeout: float) -> list[NodeEntities]:
        """Poll until nodes with every fully qualified name in ``names`` are known."""
        deadline = time.monotonic() + timeout
        while True:
            self.poll()
            found = self.nodes()
            if names <= {n.fqn for n in found} or time.monotonic() > deadline:
                return found
            self.reader.wait(min(0.05, max(deadline - time.monotonic(), 0.0)))
