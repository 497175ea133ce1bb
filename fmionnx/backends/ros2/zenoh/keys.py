"""Names on the rmw_zenoh wire: data key expressions, liveliness tokens, GIDs.

rmw_zenoh publishes a topic on ``<domain>/<topic without leading slash>/<DDS type>/<type
hash>`` and announces every node and entity with a liveliness token
``@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>``
(entities add ``/<topic>/<DDS type>/<type hash>/<qos>``), where ``/`` inside a name is written
``%`` and an empty name is ``%``. The type hash is ROS 2's RIHS01 hash, computed by rosbags
from the distribution's definitions; Humble predates type hashes and writes
``TypeHashNotSupported``, which is why Humble and newer distributions do not talk over Zenoh.
An entity's GID is the XXH3-128 hash of its liveliness key expression, its low 64 bits first
(both halves little endian, as rmw_zenoh copies the hash struct).

Nothing here opens a session: these are pure functions for the transport and the graph
reader (the tests' checker derives the same names on its own, from the wire facts).
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass

import xxhash

from fmionnx.compile.ros2.messages import RosDistro, typestore
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability

#: Admin space of the liveliness tokens.
ADMIN_SPACE = "@ros2_lv"
#: The type-hash segment of Humble, which has no type hashes.
NO_TYPE_HASH = "TypeHashNotSupported"
#: What stands for ``/`` inside one segment (and for an empty name).
SLASH = "%"
#: rmw_zenoh's history depth when a profile leaves it to the middleware.
DEFAULT_DEPTH = 42


class EntityKind(enum.StrEnum):
    """The kind segment of a liveliness token."""

    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"
    SERVICE = "SS"
    CLIENT = "SC"


def dds_type_name(msgtype: str) -> str:
    """``geometry_msgs/msg/Twist`` -> ``geometry_msgs::msg::dds_::Twist_`` (as on DDS)."""
    package, kind, name = msgtype.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def ros_type_name(dds_type: str) -> str:
    """``geometry_msgs::msg::dds_::Twist_`` -> ``geometry_msgs/msg/Twist`` (others unchanged)."""
    parts = dds_type.split("::")
    if len(parts) == 4 and parts[2] == "dds_" and parts[3].endswith("_"):
        return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
    return dds_type


@functools.cache
def type_hash(msgtype: str, distro: RosDistro) -> str:
    """``RIHS01_<sha256>`` of ``msgtype`` in ``distro``; ``TypeHashNotSupported`` on Humble."""
    if distro is RosDistro.HUMBLE:
        return NO_TYPE_HASH
    return str(typestore(distro).hash_rihs01(msgtype))


def mangle(name: str) -> str:
    """One key segment from a ROS name: ``/`` -> ``%``; empty -> ``%``."""
    return name.replace("/", SLASH) if name else SLASH


def demangle(segment: str) -> str:
    """The ROS name of a mangled segment."""
    return segment.replace(SLASH, "/")


def topic_key(domain_id: int, topic: str, msgtype: str, distro: RosDistro) -> str:
    """The data key expression of ROS topic ``topic`` (fully qualified) carrying ``msgtype``."""
    return f"{domain_id}/{topic.strip('/')}/{dds_type_name(msgtype)}/{type_hash(msgtype, distro)}"


def qos_segment(qos: QosProfile) -> str:
    """rmw_zenoh's QoS segment; a field is empty when it equals rmw_zenoh's own default.

    ``<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,<ns>:
    <liveliness>,<lease s>,<ns>`` with rmw's enum values (RELIABLE 1, BEST_EFFORT 2;
    TRANSIENT_LOCAL 1, VOLATILE 2; KEEP_LAST 1, KEEP_ALL 2). rmw_zenoh's default is reliable,
    volatile, keep-last 42 with infinite durations, so ROS 2's default profile (depth 10) reads
    ``::,10:,:,:,,``. Deadline, lifespan and liveliness are never set by fmionnx.
    """
    reliability = "2" if qos.reliability is Reliability.BEST_EFFORT else ""
    durability = "1" if qos.durability is Durability.TRANSIENT_LOCAL else ""
    history = "2" if qos.keep_all else ""
    depth = "" if qos.depth in (0, DEFAULT_DEPTH) else str(qos.depth)
    return f"{reliability}:{durability}:{history},{depth}:,:,:,,"


def parse_qos(segment: str) -> QosProfile | None:
    """The profile of a QoS segment (None when it is not one)."""
    parts = segment.split(":")
    if len(parts) < 3:
        return None
    history = parts[2].split(",")
    if len(history) < 2:
        return None
    try:
        depth = int(history[1]) if history[1] else DEFAULT_DEPTH
    except ValueError:
        return None
    reliability = Reliability.BEST_EFFORT if parts[0] == "2" else Reliability.RELIABLE
    durability = Durability.TRANSIENT_LOCAL if parts[1] == "1" else Durability.VOLATILE
    return QosProfile(reliability, durability, depth, keep_all=history[0] == "2")


def gid_of(token: str) -> bytes:
    """The 16-byte GID rmw_zenoh derives from an entity's liveliness key expression."""
    return int(xxhash.xxh3_128_intdigest(token.encode())).to_bytes(16, "little")


@dataclass(frozen=True, slots=True)
class NodeToken:
    """What names a node in the liveliness space."""

    domain_id: int
    zid: str
    node_id: int
    namespace: str
    name: str
    enclave: str = ""

    def prefix(self, entity_id: int, kind: EntityKind) -> str:
        """The token up to the node name for entity ``entity_id`` of ``kind``."""
        namespace = "" if self.namespace in ("", "/") else self.namespace
        return (
            f"{ADMIN_SPACE}/{self.domain_id}/{self.zid}/{self.node_id}/{entity_id}/{kind}/"
            f"{mangle(self.enclave)}/{mangle(namespace)}/{mangle(self.name)}"
        )

    def node(self) -> str:
        """The node's own token (its entity id is the node id)."""
        return self.prefix(self.node_id, EntityKind.NODE)

    def entity(
        self,
        entity_id: int,
        kind: EntityKind,
        topic: str,
        msgtype: str,
        qos: QosProfile,
        distro: RosDistro,
    ) -> str:
        """The token of a publisher, subscription, service or client of this node."""
        return (
            f"{self.prefix(entity_id, kind)}/{mangle(topic)}/{dds_type_name(msgtype)}/"
            f"{type_hash(msgtype, distro)}/{qos_segment(qos)}"
        )


@dataclass(frozen=True, slots=True)
class ParsedToken:
    """A liveliness token read back: who, which kind, and for entities the topic."""

    domain_id: int
    zid: str
    node_id: str
    entity_id: str
    kind: EntityKind
    enclave: str
    namespace: str
    name: str
    topic: str | None = None
    dds_type: str | None = None
    type_hash: str | None = None
    qos: QosProfile | None = None

    @property
    def fqn(self) -> str:
        """``/ns/name`` of the node the token belongs to."""
        return self.namespace.rstrip("/") + "/" + self.name

    @property
    def msgtype(self) -> str | None:
        """The ROS type of the entity's topic."""
        return None if self.dds_type is None else ros_type_name(self.dds_type)


def parse_token(key: str) -> ParsedToken | None:
    """Read a liveliness key expression; None for anything that is not an rmw_zenoh token."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != ADMIN_SPACE:
        return None
    try:
        domain_id = int(parts[1])
        kind = EntityKind(parts[5])
    except ValueError:
        return None
    namespace = demangle(parts[7])
    namespace = namespace if namespace.startswith("/") else "/" + namespace
    common = (domain_id, parts[2], parts[3], parts[4], kind, demangle(parts[6]), namespace,
              demangle(parts[8]))  # fmt: skip
    if kind is EntityKind.NODE:
        return ParsedToken(*common)
    if len(parts) < 13:
        return None
    return ParsedToken(
        *common, topic=demangle(parts[9]), dds_type=parts[10], type_hash=parts[11],
        qos=parse_qos(parts[12]),
    )  # fmt: skip
