"""Raw CDR transport through rclpy: the same bytes in and out as :mod:`.transport`, over ROS 2.

``--middleware rclpy`` runs a node's publishers and subscriptions through a real ROS 2 client
library instead of Cyclone DDS directly. The node keeps its codec and lockstep protocol: it
still hands over serialised CDR (rclpy's ``Publisher.publish`` accepts ``bytes`` and publishes
them unchanged) and reads serialised CDR (``raw=True`` subscriptions). What rclpy adds is
everything a ROS 2 node has: its name in the graph (so no ``ros_discovery_info`` of our own),
the middleware's own discovery, parameter services, ``/rosout``.

Reading: each subscription's callback appends to its queue; :meth:`RclpyReader.take` takes
waiting messages straight from the subscription's handle (what rclpy's executor does for every
message, 1 µs instead of one 100 µs executor pass per sample) and :meth:`RclpyReader.wait`
blocks in the executor. Both keep the order in which the middleware delivered the samples.

Each participant owns its rclpy context, initialised without signal handlers (the node turns
SIGTERM into KeyboardInterrupt itself) and without log files under ``~/.ros``.
"""

from __future__ import annotations

import importlib
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from fmionnx.backends.ros2.env import DdsEnvironment
from fmionnx.backends.ros2.rclpy_env import RclpyUnavailableError, import_rclpy
from fmionnx.backends.ros2.transport import TransportError, wait_for_matches
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.names import ros_topic
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability

#: rcl arguments of every participant: no spdlog files in ``~/.ros/log``.
_RCL_ARGS = ["fmionnx", "--ros-args", "--disable-external-lib-logs"]


def _message_class(msgtype: str) -> Any:
    """The generated Python class of ``pkg/msg/Name`` (rclpy needs it to create endpoints)."""
    package, _, name = msgtype.rpartition("/")
    try:
        return getattr(importlib.import_module(package.replace("/", ".")), name)
    except (ImportError, AttributeError):
        wheel = "ros-jazzy-" + msgtype.split("/", maxsplit=1)[0].replace("_", "-")
        msg = f"rclpy has no message type {msgtype} here (pip install {wheel})"
        raise RclpyUnavailableError(msg) from None


def _qos(profile: QosProfile) -> Any:
    qos = importlib.import_module("rclpy.qos")
    reliability = (
        qos.ReliabilityPolicy.RELIABLE
        if profile.reliability is Reliability.RELIABLE
        else qos.ReliabilityPolicy.BEST_EFFORT
    )
    durability = (
        qos.DurabilityPolicy.TRANSIENT_LOCAL
        if profile.durability is Durability.TRANSIENT_LOCAL
        else qos.DurabilityPolicy.VOLATILE
    )
    history = qos.HistoryPolicy.KEEP_ALL if profile.keep_all else qos.HistoryPolicy.KEEP_LAST
    return qos.QoSProfile(
        history=history, depth=profile.depth, reliability=reliability, durability=durability
    )


def _topic(dds_name: str) -> str:
    topic = ros_topic(dds_name)
    if topic is None:
        msg = f"DDS topic {dds_name} is not a ROS topic; rclpy cannot create it"
        raise TransportError(msg)
    return topic


@dataclass
class RclpyWriter:
    """An rclpy publisher fed with serialised CDR samples."""

    publisher: Any
    topic: str
    msgtype: str

    def write(self, data: bytes, stamp_ns: int | None = None) -> None:
        """Publish one sample (CDR with encapsulation header) as it is.

        rclpy's ``publish`` has no source timestamp argument (the middleware stamps the sample
        with its own clock), so ``stamp_ns`` is dropped: only a message header carries the
        simulated time through rclpy.
        """
        del stamp_ns
        self.publisher.publish(bytes(data))

    def matched(self) -> int:
        """Number of subscriptions matched right now."""
        return int(self.publisher.get_subscription_count())

    def wait_for_readers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Wait until ``count`` subscriptions matched (samples written before are lost to them)."""
        return wait_for_matches(self.matched, count, timeout)


@dataclass
class RclpyReader:
    """A raw rclpy subscription that hands out samples as CDR bytes, oldest first."""

    participant: RclpyParticipant
    topic: str
    msgtype: str
    queue: deque[bytes] = field(default_factory=deque)
    subscription: Any = None

    def deliver(self, data: bytes) -> None:
        """The subscription's callback: queue one sample the executor took."""
        self.queue.append(data)

    def take(self, limit: int = 64) -> list[bytes]:
        """Every waiting sample (up to ``limit``), oldest first; never blocks."""
        sub = self.subscription
        while len(self.queue) < limit:
            with sub.handle:
                taken = sub.handle.take_message(sub.msg_type, True)
            if taken is None:
                break
            self.queue.append(bytes(taken[0]))
        return [self.queue.popleft() for _ in range(min(limit, len(self.queue)))]

    def take_stamped(self, limit: int = 64) -> list[tuple[bytes, int | None]]:
        """Like :meth:`take`; no timestamps: an rclpy writer cannot choose its source timestamp,
        so the one received would be a wall clock, not simulated time."""
        return [(data, None) for data in self.take(limit)]

    def wait(self, timeout: float) -> bool:
        """Block until a sample is available or ``timeout`` seconds passed; True when data."""
        if not self.queue:
            self.participant.spin_once(timeout)
        return bool(self.queue)

    def matched(self) -> int:
        """Number of publishers matched right now."""
        return int(self.subscription.get_publisher_count())


class RclpyParticipant:
    """One ROS 2 node (with its own rclpy context) whose endpoints carry raw CDR."""

    def __init__(self, env: DdsEnvironment, namespace: str, name: str) -> None:
        rclpy = import_rclpy()
        self.rclpy = rclpy
        self.env = env
        self.distro: RosDistro = env.distro
        self.context = rclpy.Context()
        options = rclpy.signals.SignalHandlerOptions.NO
        try:
            rclpy.init(
                args=_RCL_ARGS, context=self.context, domain_id=env.domain_id,
                signal_handler_options=options,
            )  # fmt: skip
            self.node = rclpy.create_node(name, namespace=namespace or "/", context=self.context)
        except Exception as exc:  # rclpy raises its own RCLError types for a refused init
            self.context.try_shutdown()
            msg = f"rclpy cannot start node {namespace.rstrip('/')}/{name}: {exc}"
            raise TransportError(msg) from None
        executors = importlib.import_module("rclpy.executors")
        self.executor = executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def writer(self, dds_name: str, msgtype: str, qos: QosProfile) -> RclpyWriter:
        """A publisher on DDS topic ``dds_name`` (``rt/...``) taking serialised samples."""
        publisher = self.node.create_publisher(_message_class(msgtype), _topic(dds_name), _qos(qos))
        return RclpyWriter(publisher, dds_name, msgtype)

    def reader(self, dds_name: str, msgtype: str, qos: QosProfile) -> RclpyReader:
        """A raw subscription on DDS topic ``dds_name``."""
        reader = RclpyReader(self, dds_name, msgtype)
        reader.subscription = self.node.create_subscription(
            _message_class(msgtype), _topic(dds_name), reader.deliver,
            _qos(qos), raw=True,
        )  # fmt: skip
        return reader

    def spin_once(self, timeout: float) -> None:
        """Deliver at most one waiting sample to its subscription's queue (waits up to ``timeout``)."""
        self.executor.spin_once(timeout_sec=max(timeout, 0.0))

    def close(self) -> None:
        """Destroy the node and shut its context down."""
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    def __enter__(self) -> RclpyParticipant:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
