"""Finding a Zenoh router, or running one inside the supervisor when none is reachable.

rmw_zenoh needs a router (``rmw_zenohd``) for discovery; without one nodes reach nobody and
nothing fails. ``fmionnx run --backend ros2 --middleware zenoh`` therefore resolves
``--zenoh-router``: a URL is used as it is; ``auto`` probes the endpoints the nodes would
connect to (``tcp/localhost:7447`` unless configured otherwise) and, when none answers, opens a
Zenoh session in **router** mode inside the supervisor, listening on a free loopback port that
is passed to every node. That router lives exactly as long as the supervisor's run.
"""

from __future__ import annotations

import json
import socket
from dataclasses import dataclass
from typing import Any

from fmionnx.backends.ros2.zenoh.config import ZenohConfigError, ZenohEnvironment

#: Seconds a probe waits for a TCP connection.
PROBE_TIMEOUT = 0.5


def tcp_address(endpoint: str) -> tuple[str, int] | None:
    """Host and port of a ``tcp/host:port`` endpoint (``[::1]`` style hosts too); else None."""
    if not endpoint.startswith("tcp/"):
        return None
    address = endpoint[4:].split("#", 1)[0]
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit():
        return None
    return host.strip("[]"), int(port)


def reachable(endpoint: str, timeout: float = PROBE_TIMEOUT) -> bool:
    """Whether something accepts TCP connections at ``endpoint``."""
    address = tcp_address(endpoint)
    if address is None:
        return False
    try:
        with socket.create_connection(address, timeout=timeout):
            return True
    except OSError:
        return False


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class InProcessRouter:
    """A Zenoh session in router mode on a loopback port, closed with :meth:`close`.

    Loopback only, whatever the environment says: it serves the nodes the supervisor starts on
    this host. A run across hosts names a router the hosts can reach (``--zenoh-router``).
    """

    def __init__(self, port: int | None = None) -> None:
        import zenoh

        last: Exception | None = None
        for _ in range(5):  # a free port can be taken between the probe and the listen
            self.port = port or free_port()
            self.endpoint = f"tcp/127.0.0.1:{self.port}"
            config = zenoh.Config()
            config.insert_json5("mode", '"router"')
            config.insert_json5("listen/endpoints", json.dumps([self.endpoint]))
            config.insert_json5("connect/endpoints", "[]")
            config.insert_json5("scouting/multicast/enabled", "false")
            try:
                self.session: Any = zenoh.open(config)
                return
            except zenoh.ZError as exc:
                last = exc
                if port is not None:
                    break
        msg = f"cannot start a Zenoh router on 127.0.0.1: {last}"
        raise ZenohConfigError(msg)

    def close(self) -> None:
        """Stop routing (the nodes are gone by then)."""
        self.session.close()


@dataclass
class RouterChoice:
    """The router a run uses and, when the supervisor started it, the router itself."""

    endpoint: str
    started: InProcessRouter | None = None

    def __post_init__(self) -> None:
        self.owned = self.started is not None

    def describe(self) -> str:
        """One line for the output and run.json."""
        if self.owned:
            return f"started in-process on {self.endpoint}"
        return f"connected to {self.endpoint}"

    def close(self) -> None:
        """Close the router the supervisor started (nothing otherwise); idempotent."""
        if self.started is not None:
            self.started.close()
            self.started = None


def choose_router(spec: str, env: ZenohEnvironment) -> RouterChoice:
    """Resolve ``--zenoh-router``: ``auto`` or an endpoint such as ``tcp/10.0.0.2:7447``."""
    if spec != "auto":
        return RouterChoice(spec)
    for endpoint in env.endpoints():
        if reachable(endpoint):
            return RouterChoice(endpoint)
    router = InProcessRouter()
    return RouterChoice(router.endpoint, router)


def router_problem(spec: str) -> str | None:
    """Why ``spec`` is not a ``--zenoh-router`` value, or None."""
    if spec == "auto":
        return None
    if "/" not in spec or spec.split("/", 1)[0] not in (
        "tcp",
        "udp",
        "tls",
        "quic",
        "unixsock-stream",
    ):
        return (
            f"--zenoh-router must be `auto` or an endpoint like `tcp/localhost:7447`, not `{spec}`"
        )
    return None
