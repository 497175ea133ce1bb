"""Who can connect to a node's Zenoh session and to the router of ``--zenoh-router auto``.

Real sessions in this process; the listening sockets are read from the kernel (``/proc``),
so the test sees where Zenoh actually listens, not what the configuration asks for.
"""

from __future__ import annotations

import ipaddress
import sys
from pathlib import Path

import pytest

from fmionnx.backends.ros2.zenoh.config import zenoh_environment
from fmionnx.backends.ros2.zenoh.router import InProcessRouter, choose_router
from fmionnx.backends.ros2.zenoh.transport import ZenohTransport
from fmionnx.compile.ros2.messages import RosDistro

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="reads /proc/net")

_LISTEN = "0A"


def _socket_inodes() -> set[str]:
    """Inodes of the sockets this process holds open."""
    inodes = set()
    for fd in Path("/proc/self/fd").iterdir():
        try:
            target = str(fd.readlink())
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def _address(hex_address: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address:
    """An address of /proc/net/tcp{,6}: 32-bit words in host (little-endian) byte order."""
    words = [bytes.fromhex(hex_address[i : i + 8])[::-1] for i in range(0, len(hex_address), 8)]
    raw = b"".join(words)
    return ipaddress.IPv4Address(raw) if len(raw) == 4 else ipaddress.IPv6Address(raw)


def _listening() -> set[tuple[str, int]]:
    """(address, port) of every TCP socket of this process in the LISTEN state."""
    mine = _socket_inodes()
    found = set()
    for table in ("/proc/self/net/tcp", "/proc/self/net/tcp6"):
        if not Path(table).exists():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state != _LISTEN or inode not in mine:
                continue
            host, port = local.split(":")
            found.add((str(_address(host)), int(port, 16)))
    return found


def _loopback(address: str) -> bool:
    ip = ipaddress.ip_address(address)
    mapped = ip.ipv4_mapped if isinstance(ip, ipaddress.IPv6Address) else None
    return ip.is_loopback or (mapped is not None and mapped.is_loopback)


def test_nodes_and_the_auto_router_accept_connections_on_loopback_only(
    zenoh_domain: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", 'connect/endpoints=["tcp/127.0.0.1:1"]')
    before = _listening()
    env = zenoh_environment(RosDistro.JAZZY)
    choice = choose_router("auto", env)  # nothing answers on port 1: a router of its own
    try:
        assert isinstance(choice.started, InProcessRouter)
        router_sockets = _listening() - before
        assert router_sockets, "the router listens somewhere"
        with ZenohTransport(env.with_router(choice.endpoint), "/", "probe") as node:
            assert node.session.info.routers_zid(), "the node reached the router"
            node_sockets = _listening() - before - router_sockets
        assert node_sockets, "the node's session listens somewhere"
        exposed = {s for s in router_sockets | node_sockets if not _loopback(s[0])}
        assert not exposed, f"listening beyond loopback: {sorted(exposed)}"
    finally:
        choice.close()


def test_listen_endpoints_opened_by_the_user_are_honoured(
    zenoh_domain: int, router: InProcessRouter, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", 'listen/endpoints=["tcp/0.0.0.0:0"]')
    before = _listening()
    env = zenoh_environment(RosDistro.JAZZY, router=router.endpoint)
    with ZenohTransport(env, "/", "probe"):
        opened = _listening() - before
    assert {address for address, _ in opened} == {"0.0.0.0"}
