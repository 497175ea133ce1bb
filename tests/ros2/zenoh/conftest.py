"""Zenoh test fixtures: a router of the test's own on a free port, a domain of its own.

Every test gets both, so tests running at the same time (or a developer's real rmw_zenoh
system on port 7447) never see each other. The router runs inside the pytest process and is
closed when the test ends.
"""

from __future__ import annotations

import random
from collections.abc import Iterator

import pytest

from fmionnx.backends.ros2.zenoh.router import InProcessRouter


@pytest.fixture
def zenoh_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A random ROS_DOMAIN_ID (also for child processes); no Zenoh configuration inherited."""
    domain = random.SystemRandom().randint(100, 232)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    for name in ("ZENOH_SESSION_CONFIG_URI", "ZENOH_CONFIG_OVERRIDE", "RUST_LOG"):
        monkeypatch.delenv(name, raising=False)
    return domain


@pytest.fixture
def router(zenoh_domain: int) -> Iterator[InProcessRouter]:
    """A Zenoh router on a free loopback port, for this test only."""
    started = InProcessRouter()
    yield started
    started.close()
