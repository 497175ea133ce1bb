"""The DDS domain and Cyclone configuration, derived from the ROS 2 environment as ROS 2 does.

Participants only discover each other when their network settings agree, so this module
reproduces ``rmw_cyclonedds_cpp``'s ``check_create_domain``: Humble turns
``ROS_LOCALHOST_ONLY=1`` into "use the 127.0.0.1 interface"; Iron and later turn
``ROS_AUTOMATIC_DISCOVERY_RANGE`` (``SUBNET`` default, ``LOCALHOST``, ``OFF``,
``SYSTEM_DEFAULT``; ``ROS_LOCALHOST_ONLY=1`` still wins) and ``ROS_STATIC_PEERS`` into
multicast and peer settings. ``CYCLONEDDS_URI`` is appended last, so the user's file wins.
"""

from __future__ import annotations

import enum
import os
from collections.abc import Mapping
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.core.errors import FmionnxError

#: Cyclone maps domain ids onto UDP ports; 232 is the largest id that fits (ROS 2 docs).
MAX_DOMAIN_ID = 232


class Ros2EnvError(FmionnxError):
    """An environment variable of ROS 2 holds a value ROS 2 would reject."""


class DiscoveryRange(enum.StrEnum):
    """``ROS_AUTOMATIC_DISCOVERY_RANGE`` values (Iron and later)."""

    SUBNET = "SUBNET"
    LOCALHOST = "LOCALHOST"
    OFF = "OFF"
    SYSTEM_DEFAULT = "SYSTEM_DEFAULT"


@dataclass(frozen=True, slots=True)
class DdsEnvironment:
    """Where participants live: domain id, discovery range, peers, user configuration."""

    distro: RosDistro
    domain_id: int = 0
    discovery: DiscoveryRange = DiscoveryRange.SUBNET
    static_peers: tuple[str, ...] = ()
    cyclonedds_uri: str = ""

    @property
    def localhost_only(self) -> bool:
        """True when traffic stays on this host."""
        return self.discovery in (DiscoveryRange.LOCALHOST, DiscoveryRange.OFF)

    def cyclone_config(self) -> str:
        """The configuration string given to ``dds_create_domain`` (comma-separated fragments)."""
        fragments = [self._ros_fragment(), self.cyclonedds_uri]
        return ",".join(f for f in fragments if f)

    def _ros_fragment(self) -> str:
        if self.distro is RosDistro.HUMBLE:
            if self.discovery is DiscoveryRange.SUBNET:
                return ""
            # Loopback as rmw_cyclonedds_cpp does, and multicast for discovery only: with data
            # by multicast, a small /clock tick (several readers: multicast) can overtake a large
            # frame (one reader: unicast), which arrives on another receive thread, and a
            # free-run detector steps on the previous frame (docs/performance.md, ROS 2 mode).
            return (
                "<CycloneDDS><Domain><General><Interfaces>"
                '<NetworkInterface address="127.0.0.1"/>'
                "</Interfaces><AllowMulticast>spdp</AllowMulticast></General></Domain></CycloneDDS>"
            )
        add_localhost = self.discovery is DiscoveryRange.LOCALHOST
        add_peers = self.discovery in (DiscoveryRange.SUBNET, DiscoveryRange.LOCALHOST)
        no_multicast = self.discovery in (DiscoveryRange.LOCALHOST, DiscoveryRange.OFF)
        peers = list(self.static_peers) if add_peers else []
        if not (add_localhost or peers or no_multicast):
            return ""
        parts = ["<CycloneDDS><Domain>"]
        if no_multicast:
            general = f"{self._loopback_interface()}<AllowMulticast>false</AllowMulticast>"
            parts.append(f"<General>{general}</General>")
        if self.discovery is DiscoveryRange.OFF:
            parts.append(
                "<Discovery><ParticipantIndex>none</ParticipantIndex>"
                f"<Tag>ros_discovery_off_{os.getpid()}</Tag>"
            )
        else:
            parts.append(
                "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
                "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
            )
        if add_localhost or peers:
            parts.append("<Peers>")
            if add_localhost:
                parts.append('<Peer address="localhost"/>')
            parts.extend(f"<Peer address={quoteattr(p)}/>" for p in peers)
            parts.append("</Peers>")
        parts.append("</Discovery></Domain></CycloneDDS>")
        return "".join(parts)

    def _loopback_interface(self) -> str:
        """Loopback as Cyclone's interface when nothing may leave this host.

        rmw_cyclonedds_cpp keeps the automatically chosen interface here, so its locators name
        the host's LAN address; rmw_fastrtps_cpp (ROS 2's default middleware) in the same range
        only talks over 127.0.0.1 and never reaches them: ``ros2 node list`` would not see the
        nodes. With loopback selected, Fast DDS and Cyclone participants in the LOCALHOST range
        discover each other (checked against rclpy from the ROS 2 wheels). Static peers live on
        other hosts and need a real interface, so they keep Cyclone's choice.
        """
        if self.discovery is DiscoveryRange.LOCALHOST and not self.static_peers:
            return '<Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
        return ""


def _domain_id(text: str) -> int:
    if not text.strip():
        return 0
    try:
        value = int(text.strip())
    except ValueError:
        msg = f"ROS_DOMAIN_ID={text!r} is not a whole number (expected 0 to {MAX_DOMAIN_ID})"
        raise Ros2EnvError(msg) from None
    if not 0 <= value <= MAX_DOMAIN_ID:
        msg = f"ROS_DOMAIN_ID={value} is out of range (expected 0 to {MAX_DOMAIN_ID})"
        raise Ros2EnvError(msg)
    return value


def _localhost_only(text: str) -> bool:
    # rcl: only the exact value "1" enables it; "0" and "" disable it.
    return text.strip() == "1"


def from_environment(distro: RosDistro, environ: Mapping[str, str] | None = None) -> DdsEnvironment:
    """Read ``ROS_DOMAIN_ID``, ``ROS_LOCALHOST_ONLY``, ``ROS_AUTOMATIC_DISCOVERY_RANGE``,
    ``ROS_STATIC_PEERS`` and ``CYCLONEDDS_URI`` the way ``distro`` reads them.

    Raises :class:`Ros2EnvError` for a value ROS 2 would refuse.
    """
    env = os.environ if environ is None else environ
    domain_id = _domain_id(env.get("ROS_DOMAIN_ID", ""))
    uri = env.get("CYCLONEDDS_URI", "")
    localhost = _localhost_only(env.get("ROS_LOCALHOST_ONLY", ""))
    if distro is RosDistro.HUMBLE:
        discovery = DiscoveryRange.LOCALHOST if localhost else DiscoveryRange.SUBNET
        return DdsEnvironment(distro, domain_id, discovery, (), uri)
    if localhost:
        return DdsEnvironment(distro, domain_id, DiscoveryRange.LOCALHOST, (), uri)
    text = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip()
    if not text:
        discovery = DiscoveryRange.SUBNET
    else:
        try:
            discovery = DiscoveryRange(text.upper())
        except ValueError:
            names = ", ".join(r.value for r in DiscoveryRange)
            msg = f"ROS_AUTOMATIC_DISCOVERY_RANGE={text!r} is not one of {names}"
            raise Ros2EnvError(msg) from None
    peers = tuple(p.strip() for p in env.get("ROS_STATIC_PEERS", "").split(";") if p.strip())
    return DdsEnvironment(distro, domain_id, discovery, peers, uri)
