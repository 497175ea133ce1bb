"""A local cluster's workers each on cores of their own (``fmionnx.backends.sweep.pinning``):
the cores cut into equal shares, every thread of a worker confined to its share, a master
confined to one core not spinning on its children, and ``FMIONNX_PIN_WORKERS=0`` leaving the
placement to the system."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import cloudpickle
import pytest

from fmionnx.backends.sweep import engine, pinning
from fmionnx.runtime.isolated import proxy


@pytest.mark.parametrize(
    ("workers", "shares"),
    [
        (1, None),  # all cores its own
        (2, [[0, 1], [2, 3]]),
        (3, [[0, 1], [2], [3]]),  # as equal as they come: every core has a worker
        (4, [[0], [1], [2], [3]]),
        (5, None),  # more workers than cores: the system places them
    ],
)
def test_the_cores_are_cut_into_equal_shares(
    workers: int, shares: list[list[int]] | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {3, 1, 0, 2})
    assert pinning.cores_for(workers) == shares


def test_switched_off_nothing_is_pinned(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setenv(pinning.SWITCH, "0")
    assert pinning.cores_for(2) is None


def test_a_supervisor_on_one_core_does_not_spin(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    assert proxy.supervisor_spin_ns() == proxy.SPIN_NS
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {1})
    assert proxy.supervisor_spin_ns() == 0


def _placement() -> list[tuple[int, ...]]:
    """In a worker: the distinct core sets of its threads."""
    threads = Path("/proc/self/task").iterdir()
    return sorted({tuple(sorted(os.sched_getaffinity(int(t.name)))) for t in threads})


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="needs 2 cores")
@pytest.mark.parametrize("pinned", [True, False])
def test_each_worker_of_a_local_cluster_runs_on_its_own_core(
    pinned: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    if not pinned:
        monkeypatch.setenv(pinning.SWITCH, "0")
    every = tuple(sorted(os.sched_getaffinity(0)))
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import us
    with engine.open_client(workers=2) as client:
        client.wait_for_workers(2)
        placements = sorted(client.run(_placement).values())
    if pinned:
        shares = pinning.cores_for(2)
        assert shares is not None
        assert placements == sorted([[tuple(share)] for share in shares])
        assert len(every) > 2 or placements == [[(every[0],)], [(every[1],)]]
    else:
        assert placements == [[every], [every]]
