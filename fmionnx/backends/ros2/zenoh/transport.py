"""A node's transport on the rmw_zenoh wire: writers and readers of serialised CDR.

One Zenoh session per node process (rmw_zenoh: one per context). The session declares the
node's liveliness token, then one token per writer (``MP``) and reader (``MS``) with the
entity's QoS, and publishes each sample on the topic's key expression with the 33-byte
attachment (:mod:`.attachment`). Node and entity ids come from one counter per session, the
GIDs from the tokens (:func:`.keys.gid_of`), exactly as rmw_zenoh does, so ``ros2 node list``
and ``ros2 topic info -v`` of a ROS 2 system on rmw_zenoh show these nodes like their own.

Durability: TRANSIENT_LOCAL writers keep their last ``depth`` samples in a Zenoh advanced
publisher's cache and TRANSIENT_LOCAL readers ask late joiners for them (advanced subscriber
with history), which is rmw_zenoh's mapping too. Reliable writers block when the network
queue is full, best-effort writers drop.

Samples are handed over without per-element work: the payload is the codec's ``bytes`` (one
copy into Zenoh), the reader keeps Zenoh's payload as ``bytes``. Between peers on one host,
zenoh-python (1.6 and later) moves payloads above 3 KB through shared memory by itself
(``transport/shared_memory``, on by default; the reader counts such samples), so a camera frame
does not cross a socket. A reader delivers each
publisher's samples at most once, in the order of their sequence numbers: a sample whose
sequence number it has already passed (the history reply of a sample that also arrived live)
is dropped.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any, ClassVar

from fmionnx.backends.ros2.transport import TransportError
from fmionnx.backends.ros2.zenoh import attachment
from fmionnx.backends.ros2.zenoh.config import ZenohConfigError, ZenohEnvironment
from fmionnx.backends.ros2.zenoh.graph_cache import GraphCache
from fmionnx.backends.ros2.zenoh.keys import EntityKind, NodeToken, gid_of, topic_key
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.names import ros_topic
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability
from fmionnx.runtime.stopping import shield_begin, shield_end

#: Longest a stop signal waits for a reader's wait to let it through (see ``wait``).
WAIT_SLICE = 0.05


def _ros_name(dds_name: str) -> str:
    topic = ros_topic(dds_name)
    if topic is None:
        msg = f"DDS topic {dds_name} is not a ROS topic; it has no key on the Zenoh wire"
        raise TransportError(msg)
    return topic


class _ZenohEntity:
    """What a writer and a reader share: the topic's key, a Zenoh handle, a liveliness token.

    The handle (publisher or subscriber) is declared before the entity's token, so the graph
    never shows an entity that cannot carry data yet; the GID follows from the token.
    """

    kind: ClassVar[EntityKind]

    def __init__(
        self, transport: ZenohTransport, topic: str, msgtype: str, qos: QosProfile
    ) -> None:
        self.transport = transport
        self.topic = topic
        self.msgtype = msgtype
        self.qos = qos
        self.key = topic_key(transport.domain_id, topic, msgtype, transport.distro)
        self.handle: Any = self._declare(transport.session)
        self.token = transport.declare_entity(self.kind, topic, msgtype, qos)
        self.gid = gid_of(self.token)

    def _declare(self, session: Any) -> Any:
        """The Zenoh publisher or subscriber on :attr:`key`."""
        raise NotImplementedError

    def undeclare(self) -> None:
        """Undeclare the handle (the token goes with the transport's)."""
        self.handle.undeclare()


class ZenohWriter(_ZenohEntity):
    """Publishes serialised samples with rmw_zenoh's attachment."""

    kind = EntityKind.PUBLISHER

    def __init__(
        self, transport: ZenohTransport, topic: str, msgtype: str, qos: QosProfile
    ) -> None:
        super().__init__(transport, topic, msgtype, qos)
        self.sequence = 0

    @property
    def publisher(self) -> Any:
        """The Zenoh publisher (an advanced one for TRANSIENT_LOCAL)."""
        return self.handle

    def _declare(self, session: Any) -> Any:
        import zenoh
        import zenoh.ext

        congestion = (
            zenoh.CongestionControl.BLOCK
            if self.qos.reliability is Reliability.RELIABLE
            else zenoh.CongestionControl.DROP
        )
        if self.qos.durability is Durability.TRANSIENT_LOCAL:
            return zenoh.ext.declare_advanced_publisher(
                session, self.key, congestion_control=congestion,
                cache=zenoh.ext.CacheConfig(max(self.qos.depth, 1)), publisher_detection=True,
            )  # fmt: skip
        return session.declare_publisher(self.key, congestion_control=congestion)

    def write(self, data: bytes, stamp_ns: int | None = None) -> None:
        """Publish one sample; ``stamp_ns`` (simulated time) or the wall clock is its source time."""
        self.sequence += 1
        stamp = time.time_ns() if stamp_ns is None else stamp_ns
        self.handle.put(data, attachment=attachment.encode(self.sequence, stamp, self.gid))

    def matched(self) -> int:
        """Subscriptions of this topic alive in the graph (this process's own included)."""
        return self.transport.graph.count(EntityKind.SUBSCRIPTION, self.topic)

    def wait_for_readers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Wait until ``count`` subscriptions of the topic are alive."""
        return self.transport.graph.wait_for(EntityKind.SUBSCRIPTION, self.topic, count, timeout)


class ZenohReader(_ZenohEntity):
    """Queues samples as they arrive (a zenoh callback thread) and hands them out in order."""

    kind = EntityKind.SUBSCRIPTION

    def __init__(
        self, transport: ZenohTransport, topic: str, msgtype: str, qos: QosProfile
    ) -> None:
        # The queue exists before the subscriber: its callback may run at once.
        self._queue: deque[tuple[bytes, int | None]] = deque(
            maxlen=None if qos.keep_all else max(qos.depth, 1)
        )
        self._arrived = threading.Condition()
        self._last: dict[bytes, int] = {}
        self.dropped_duplicates = 0
        #: Samples whose payload arrived in Zenoh shared memory (same host, large payloads).
        self.shared_memory_samples = 0
        super().__init__(transport, topic, msgtype, qos)

    @property
    def subscriber(self) -> Any:
        """The Zenoh subscriber (an advanced one for TRANSIENT_LOCAL)."""
        return self.handle

    def _declare(self, session: Any) -> Any:
        import zenoh.ext

        if self.qos.durability is Durability.TRANSIENT_LOCAL:
            history = zenoh.ext.HistoryConfig(
                detect_late_publishers=True, max_samples=max(self.qos.depth, 1)
            )
            return zenoh.ext.declare_advanced_subscriber(
                session, self.key, self._on_sample, history=history
            )
        return session.declare_subscriber(self.key, self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        payload = sample.payload
        data = payload.to_bytes()
        in_shm = payload.as_shm() is not None
        extra = sample.attachment
        stamp: int | None = None
        with self._arrived:
            if extra is not None:
                try:
                    info = attachment.decode(extra.to_bytes())
                except attachment.AttachmentError:
                    info = None
                if info is not None:
                    stamp = info.timestamp_ns
                    last = self._last.get(info.gid)
                    if last is not None and info.sequence <= last:
                        self.dropped_duplicates += 1
                        return
                    self._last[info.gid] = info.sequence
            self.shared_memory_samples += in_shm
            self._queue.append((data, stamp))
            self._arrived.notify_all()

    def take_stamped(self, limit: int = 64) -> list[tuple[bytes, int | None]]:
        """Waiting samples with their attachment's source time (None without one), oldest first."""
        with self._arrived:
            count = min(limit, len(self._queue))
            return [self._queue.popleft() for _ in range(count)]

    def take(self, limit: int = 64) -> list[bytes]:
        """Waiting samples, oldest first, never blocking."""
        return [data for data, _ in self.take_stamped(limit)]

    def wait(self, timeout: float) -> bool:
        """Block until a sample is waiting or ``timeout`` seconds passed; True when one is.

        A stop signal (Ctrl-C) raised inside ``Condition.wait`` can cut it between releasing
        and taking back its lock ("cannot release un-acquired lock", a traceback instead of a
        clean stop): the wait is shielded, in slices of :data:`WAIT_SLICE`, and the signal is
        raised between two slices.
        """
        deadline = time.monotonic() + max(timeout, 0.0)
        while True:
            shield_begin()
            try:
                with self._arrived:
                    if not self._queue:
                        left = deadline - time.monotonic()
                        self._arrived.wait(min(max(left, 0.0), WAIT_SLICE))
                    if self._queue:
                        return True
            finally:
                shield_end()  # raises the stop signal held during the slice, if one came
            if time.monotonic() >= deadline:
                return False

    def matched(self) -> int:
        """Publishers of this topic alive in the graph."""
        return self.transport.graph.count(EntityKind.PUBLISHER, self.topic)


class ZenohTransport:
    """One node on the rmw_zenoh wire: a session, its liveliness tokens, writers and readers."""

    def __init__(
        self, env: ZenohEnvironment, namespace: str, name: str, *, enclave: str = ""
    ) -> None:
        import zenoh

        self.env = env
        self.distro: RosDistro = env.distro
        self.domain_id = env.domain_id
        config = env.config()
        try:
            self.session: Any = zenoh.open(config)
        except zenoh.ZError as exc:
            msg = f"cannot open a Zenoh session: {exc}"
            raise ZenohConfigError(msg) from None
        self.zid = str(self.session.zid())
        self._ids = 0
        self._tokens: list[Any] = []
        self.graph = GraphCache(self.session, self.domain_id)
        self.node = NodeToken(self.domain_id, self.zid, self._next_id(), namespace, name, enclave)
        self.node_key = self.node.node()
        self._tokens.append(self.session.liveliness().declare_token(self.node_key))
        self.entities: list[ZenohWriter | ZenohReader] = []

    def _next_id(self) -> int:
        value = self._ids
        self._ids += 1
        return value

    def declare_entity(self, kind: EntityKind, topic: str, msgtype: str, qos: QosProfile) -> str:
        """Declare the liveliness token of a new entity of this node; its key expression."""
        key = self.node.entity(self._next_id(), kind, topic, msgtype, qos, self.distro)
        self._tokens.append(self.session.liveliness().declare_token(key))
        return key

    def writer(self, dds_name: str, msgtype: str, qos: QosProfile) -> ZenohWriter:
        """A writer on the ROS topic of DDS name ``dds_name`` (``rt/...``)."""
        writer = ZenohWriter(self, _ros_name(dds_name), msgtype, qos)
        self.entities.append(writer)
        return writer

    def reader(self, dds_name: str, msgtype: str, qos: QosProfile) -> ZenohReader:
        """A reader on the ROS topic of DDS name ``dds_name``."""
        reader = ZenohReader(self, _ros_name(dds_name), msgtype, qos)
        self.entities.append(reader)
        return reader

    def close(self) -> None:
        """Undeclare everything and close the session (its tokens vanish from the graph)."""
        if self.session.is_closed():
            return
        for entity in self.entities:
            entity.undeclare()
        for token in self._tokens:
            token.undeclare()
        self.graph.close()
        self.session.close()

    def __enter__(self) -> ZenohTransport:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
