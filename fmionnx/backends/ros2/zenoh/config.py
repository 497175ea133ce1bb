"""The Zenoh session of a node, configured from the environment as rmw_zenoh configures it.

rmw_zenoh opens every context's session in **peer** mode with multicast scouting off,
connects it to a router on ``tcp/localhost:7447`` and lets it listen on ``tcp/localhost:0``
only: the router is the discovery point, data then flows between the peers of one host
directly, and traffic between hosts goes through routers. A session listening on every
interface (Zenoh's own default, ``tcp/[::]:0``) would let any host that reaches the machine
connect and publish samples that a node decodes into model inputs. The user changes that the same two ways as with rmw_zenoh:
``ZENOH_SESSION_CONFIG_URI`` names a JSON5 configuration file that replaces the defaults, and
``ZENOH_CONFIG_OVERRIDE='key=value;key=value'`` changes single keys afterwards
(``connect/endpoints=["tcp/10.0.0.2:7447"]``). ``ROS_DOMAIN_ID`` is part of every key, so it
is read here too. A router chosen on the command line (``--zenoh-router``) wins over all of it:
that is where the supervisor's nodes must meet.

Everything is checked before a session opens: a wrong file, key or value is a clear
:class:`ZenohConfigError`, never a Rust panic in a node's log.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmionnx.backends.ros2.env import Ros2EnvError, from_environment
from fmionnx.compile.ros2.messages import RosDistro

#: rmw_zenoh's default router endpoint.
DEFAULT_ROUTER = "tcp/localhost:7447"
#: rmw_zenoh's default listen endpoint: loopback only, a free port.
DEFAULT_LISTEN = "tcp/localhost:0"
CONFIG_URI_ENV = "ZENOH_SESSION_CONFIG_URI"
CONFIG_OVERRIDE_ENV = "ZENOH_CONFIG_OVERRIDE"


class ZenohConfigError(Ros2EnvError):
    """The Zenoh configuration from the environment or the command line is unusable."""


@dataclass(frozen=True, slots=True)
class ZenohEnvironment:
    """Where a node's session goes: distribution, domain, config file, overrides, router."""

    distro: RosDistro
    domain_id: int = 0
    config_uri: str = ""
    overrides: tuple[tuple[str, str], ...] = ()
    #: A router endpoint that replaces ``connect/endpoints`` (``--zenoh-router``); "" keeps them.
    router: str = ""

    def with_router(self, router: str) -> ZenohEnvironment:
        """The same environment connecting to ``router``."""
        return ZenohEnvironment(
            self.distro, self.domain_id, self.config_uri, self.overrides, router
        )

    def config(self, *, mode: str = "peer") -> Any:
        """A ``zenoh.Config`` for a session in ``mode`` (imports zenoh)."""
        import zenoh

        try:
            if self.config_uri:
                config = zenoh.Config.from_file(self.config_uri)
            else:
                config = zenoh.Config()
                config.insert_json5("mode", json.dumps(mode))
                config.insert_json5("connect/endpoints", json.dumps([DEFAULT_ROUTER]))
                config.insert_json5("listen/endpoints", json.dumps([DEFAULT_LISTEN]))
                config.insert_json5("scouting/multicast/enabled", "false")
            # Transient-local publishers need timestamps (rmw_zenoh's own default config too).
            config.insert_json5("timestamping/enabled", "true")
        except zenoh.ZError as exc:
            msg = f"{CONFIG_URI_ENV}={self.config_uri}: {_reason(exc)}"
            raise ZenohConfigError(msg) from None
        for key, value in self.overrides:
            try:
                config.insert_json5(key, value)
            except zenoh.ZError as exc:
                msg = f"{CONFIG_OVERRIDE_ENV}: `{key}={value}`: {_reason(exc)}"
                raise ZenohConfigError(msg) from None
        if self.router:
            config.insert_json5("connect/endpoints", json.dumps([self.router]))
        return config

    def endpoints(self) -> list[str]:
        """The endpoints a session of this environment connects to."""
        return self._peer_endpoints("connect/endpoints")

    def listen_endpoints(self) -> list[str]:
        """The endpoints a session of this environment listens on."""
        return self._peer_endpoints("listen/endpoints")

    def _peer_endpoints(self, key: str) -> list[str]:
        """The endpoint list at ``key`` of a peer session's configuration."""
        try:
            value = json.loads(self.config().get_json(key))
        except (ValueError, TypeError):
            return []
        if isinstance(value, dict):  # per-mode endpoints: {"peer": [...], "router": [...]}
            value = value.get("peer", [])
        return [str(e) for e in value] if isinstance(value, list) else []


def _reason(exc: Exception) -> str:
    """The message of a zenoh error without the Rust source location it appends."""
    text = str(exc)
    return text.split(" at /", 1)[0].removeprefix('Str("').removesuffix('")')


def parse_overrides(text: str) -> tuple[tuple[str, str], ...]:
    """``key=value;key=value`` as pairs; :class:`ZenohConfigError` for a part without ``=``."""
    pairs = []
    for part in _split_outside_brackets(text):
        if not part.strip():
            continue
        key, sep, value = part.partition("=")
        if not sep or not key.strip():
            msg = f"{CONFIG_OVERRIDE_ENV}: `{part}` must look like `key=value`"
            raise ZenohConfigError(msg)
        pairs.append((key.strip(), value.strip()))
    return tuple(pairs)


def _split_outside_brackets(text: str) -> list[str]:
    """Split on ``;`` except inside ``[...]``, ``{...}`` or quotes (JSON5 values)."""
    parts, depth, quote, start = [], 0, "", 0
    for i, char in enumerate(text):
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        elif char == ";" and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def zenoh_environment(
    distro: RosDistro, environ: Mapping[str, str] | None = None, *, router: str = ""
) -> ZenohEnvironment:
    """Read ``ROS_DOMAIN_ID``, ``ZENOH_SESSION_CONFIG_URI`` and ``ZENOH_CONFIG_OVERRIDE``."""
    env = os.environ if environ is None else environ
    domain_id = from_environment(distro, env).domain_id
    uri = env.get(CONFIG_URI_ENV, "").strip()
    if uri and not Path(uri).is_file():
        msg = f"{CONFIG_URI_ENV}={uri}: no such file (expected a Zenoh JSON5 configuration)"
        raise ZenohConfigError(msg)
    overrides = parse_overrides(env.get(CONFIG_OVERRIDE_ENV, ""))
    return ZenohEnvironment(distro, domain_id, uri, overrides, router)
