"""What rmw_zenoh calls the graph cache: every liveliness token alive in one domain.

A session subscribes to ``@ros2_lv/<domain>/**`` with history (the tokens already declared are
reported at once) and keeps the parsed tokens by key; a token's disappearance (its session
closed or crashed) is a DELETE sample. Writers count the subscriptions of their topic from it
(``matched``), the graph command lists nodes and endpoints from it.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from fmionnx.backends.ros2.zenoh.keys import ADMIN_SPACE, EntityKind, ParsedToken, parse_token


class GraphCache:
    """Alive liveliness tokens of one domain, updated by a zenoh callback thread."""

    def __init__(self, session: Any, domain_id: int) -> None:
        import zenoh

        self._put = zenoh.SampleKind.PUT
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self.tokens: dict[str, ParsedToken] = {}
        self.foreign: set[str] = set()  # keys in the admin space that are not rmw_zenoh tokens
        self._subscriber = session.liveliness().declare_subscriber(
            f"{ADMIN_SPACE}/{domain_id}/**", self._on_sample, history=True
        )

    def _on_sample(self, sample: Any) -> None:
        key = str(sample.key_expr)
        token = parse_token(key)
        with self._changed:
            if sample.kind == self._put:
                if token is None:
                    self.foreign.add(key)
                else:
                    self.tokens[key] = token
            else:
                self.tokens.pop(key, None)
                self.foreign.discard(key)
            self._changed.notify_all()

    def snapshot(self) -> list[ParsedToken]:
        """The tokens alive right now."""
        with self._lock:
            return list(self.tokens.values())

    def count(self, kind: EntityKind, topic: str) -> int:
        """Entities of ``kind`` on ROS topic ``topic`` alive right now."""
        with self._lock:
            return sum(1 for t in self.tokens.values() if t.kind is kind and t.topic == topic)

    def wait_for(self, kind: EntityKind, topic: str, count: int, timeout: float) -> bool:
        """Wait until ``count`` entities of ``kind`` on ``topic`` are alive; False on timeout."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                alive = sum(1 for t in self.tokens.values() if t.kind is kind and t.topic == topic)
                left = deadline - time.monotonic()
                if alive >= count:
                    return True
                if left <= 0:
                    return False
                self._changed.wait(left)

    def close(self) -> None:
        """Stop following the graph."""
        self._subscriber.undeclare()
