"""A minimal rmw_zenoh observer written directly on ``eclipse-zenoh`` from the wire facts.

Deliberately independent of ``fmionnx.backends.ros2.zenoh``: it parses liveliness tokens,
data key expressions and attachments itself (``shared/ros2-zenoh.md``), so that a mistake in
the transport is not repeated here. It records every liveliness token ever seen in a domain
and, for every data sample, the key, the attachment's sequence number, time and GID.
"""

from __future__ import annotations

import json
import struct
import threading
from dataclasses import dataclass, field
from typing import Any

import xxhash
import zenoh


@dataclass
class Seen:
    """What the checker observed."""

    tokens: set[str] = field(default_factory=set)
    #: data key -> [(sequence, timestamp ns, gid)]
    samples: dict[str, list[tuple[int, int, bytes]]] = field(default_factory=dict)
    no_attachment: list[str] = field(default_factory=list)
    malformed: list[str] = field(default_factory=list)


class Checker:
    """Subscribes to ``@ros2_lv/<domain>/**`` and ``<domain>/**`` through ``endpoint``."""

    def __init__(self, endpoint: str, domain: int) -> None:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("connect/endpoints", json.dumps([endpoint]))
        config.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(config)
        self.seen = Seen()
        self._lock = threading.Lock()
        self._tokens = self.session.liveliness().declare_subscriber(
            f"@ros2_lv/{domain}/**", self._token, history=True
        )
        self._data = self.session.declare_subscriber(f"{domain}/**", self._sample)

    def _token(self, sample: Any) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            with self._lock:
                self.seen.tokens.add(str(sample.key_expr))

    def _sample(self, sample: Any) -> None:
        key = str(sample.key_expr)
        extra = sample.attachment
        with self._lock:
            if extra is None:
                self.seen.no_attachment.append(key)
                return
            raw = extra.to_bytes()
            if len(raw) != 33 or raw[16] != 16:
                self.seen.malformed.append(key)
                return
            sequence, stamp, _ = struct.unpack_from("<qqB", raw)
            self.seen.samples.setdefault(key, []).append((sequence, stamp, raw[17:33]))

    def close(self) -> Seen:
        """Stop observing; what was seen."""
        self._tokens.undeclare()
        self._data.undeclare()
        self.session.close()
        return self.seen


def nodes(tokens: set[str]) -> set[str]:
    """``/name`` of every node token (namespace ``%`` = ``/``)."""
    found = set()
    for key in tokens:
        parts = key.split("/")
        if parts[5] == "NN":
            namespace = parts[7].replace("%", "/")
            found.add(namespace.rstrip("/") + "/" + parts[8])
    return found


def endpoints(tokens: set[str], kind: str) -> set[tuple[str, str, str]]:
    """``(node, topic, ros type)`` of every ``MP`` or ``MS`` token."""
    found = set()
    for key in tokens:
        parts = key.split("/")
        if parts[5] != kind:
            continue
        node = parts[7].replace("%", "/").rstrip("/") + "/" + parts[8]
        package, msg, _, name = parts[10].split("::")
        found.add((node, parts[9].replace("%", "/"), f"{package}/{msg}/{name[:-1]}"))
    return found


def publisher_gids(tokens: set[str]) -> dict[bytes, str]:
    """GID (XXH3-128 of the token, low half first) -> the publisher token."""
    gids = {}
    for key in tokens:
        if key.split("/")[5] == "MP":
            value = xxhash.xxh3_128_intdigest(key.encode())
            gids[struct.pack("<QQ", value & (2**64 - 1), value >> 64)] = key
    return gids
