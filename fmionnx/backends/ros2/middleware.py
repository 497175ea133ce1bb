"""Which library carries a node's samples: Cyclone DDS directly (``dds``), rclpy (``rclpy``) or
the rmw_zenoh wire (``zenoh``, :mod:`.zenoh`).

Both hand the node the same thing: writers that publish serialised CDR and readers that return
it, so the codec and the lockstep protocol do not know which one runs. ``dds`` is the default
(no ROS 2 installation needed); the node then announces itself on ``ros_discovery_info``.
``rclpy`` makes each node a real rclpy node, which announces itself.
"""

from __future__ import annotations

import enum
from typing import Protocol

from fmionnx.backends.ros2.env import DdsEnvironment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import QosProfile


class Middleware(enum.StrEnum):
    """``--middleware`` values."""

    DDS = "dds"
    RCLPY = "rclpy"
    ZENOH = "zenoh"


class SampleWriter(Protocol):
    """Publishes serialised samples (:class:`~.transport.RawWriter`, ``RclpyWriter``)."""

    def write(self, data: bytes, stamp_ns: int | None = None) -> None:
        """Publish one sample; ``stamp_ns``: the simulated time (ns) of the step whose outputs it
        carries, sent as the sample's source timestamp where the middleware can (free-run
        readers match headerless messages by it); None: the middleware's own clock."""

    def matched(self) -> int:
        """Readers matched right now."""

    def wait_for_readers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Wait until ``count`` readers matched."""


class SampleReader(Protocol):
    """Returns serialised samples (:class:`~.transport.RawReader`, ``RclpyReader``)."""

    def take(self, limit: int = 64) -> list[bytes]:
        """Waiting samples, oldest first, never blocking."""

    def take_stamped(self, limit: int = 64) -> list[tuple[bytes, int | None]]:
        """Waiting samples with their source timestamps (ns; None where the middleware cannot
        carry one the writer chose), oldest first, never blocking."""

    def wait(self, timeout: float) -> bool:
        """Block until a sample is available; True when one is."""

    def matched(self) -> int:
        """Writers matched right now."""


class NodeTransport(Protocol):
    """Creates a node's writers and readers by DDS topic name (``rt/...``)."""

    distro: RosDistro

    def writer(self, dds_name: str, msgtype: str, qos: QosProfile) -> SampleWriter:
        """A writer of serialised ``msgtype`` samples."""

    def reader(self, dds_name: str, msgtype: str, qos: QosProfile) -> SampleReader:
        """A reader of serialised ``msgtype`` samples."""

    def close(self) -> None:
        """Delete everything the transport created."""


def open_transport(
    middleware: Middleware,
    env: DdsEnvironment,
    namespace: str,
    name: str,
    *,
    zenoh_router: str = "",
) -> NodeTransport:
    """The transport of node ``namespace/name`` (rclpy and zenoh are imported only when asked
    for; ``zenoh_router``: the endpoint a Zenoh node connects to, "" for its configuration's)."""
    if middleware is Middleware.ZENOH:
        from fmionnx.backends.ros2.zenoh.config import zenoh_environment
        from fmionnx.backends.ros2.zenoh.transport import ZenohTransport

        return ZenohTransport(zenoh_environment(env.distro, router=zenoh_router), namespace, name)
    if middleware is Middleware.RCLPY:
        from fmionnx.backends.ros2.rclpy_transport import RclpyParticipant

        return RclpyParticipant(env, namespace, name)
    return Participant(env)
