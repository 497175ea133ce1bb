"""The SSP unpack cache is bounded: old entries and, beyond a size, the least recently used go.

Archives are real zips with real test FMUs; every unpack goes through ``unpack_ssp``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from fmionnx.core.cachedir import IN_USE_SECONDS, evict
from fmionnx.spec.ssp_archive import cache_root, unpack_ssp
from tests.ssp.conftest import write_ssp
from tests.ssp.test_import import gain, ssd

DAY = 86400


def _ssp(path: Path, fmu: Path, tag: str) -> Path:
    """An archive with Gain.fmu; ``tag`` makes its bytes (and cache entry) distinct."""
    body = f"<ssd:Elements>{gain('a')}</ssd:Elements><!-- {tag} -->"
    return write_ssp(path, {"SystemStructure.ssd": ssd(body), "resources/Gain.fmu": fmu})


def _age(entry: Path, seconds: float) -> None:
    then = time.time() - seconds
    os.utime(entry, (then, then))


@pytest.fixture
def gain_fmu(fixture_fmu) -> Path:  # type: ignore[no-untyped-def]
    path: Path = fixture_fmu("Gain")
    return path


def test_entries_unused_for_longer_than_the_age_limit_are_removed(
    tmp_path: Path, gain_fmu: Path
) -> None:
    old = unpack_ssp(_ssp(tmp_path / "old.ssp", gain_fmu, "old"))
    _age(old, 31 * DAY)
    new = unpack_ssp(_ssp(tmp_path / "new.ssp", gain_fmu, "new"))
    assert new.is_dir()
    assert not old.exists()


def test_beyond_the_size_limit_the_least_recently_used_go_first(
    tmp_path: Path, gain_fmu: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = unpack_ssp(_ssp(tmp_path / "first.ssp", gain_fmu, "first"))
    second = unpack_ssp(_ssp(tmp_path / "second.ssp", gain_fmu, "second"))
    _age(first, 3 * IN_USE_SECONDS)
    _age(second, 2 * IN_USE_SECONDS)
    unpack_ssp(tmp_path / "first.ssp")  # a cache hit marks `first` as used now
    assert time.time() - first.stat().st_mtime < 60
    entry_bytes = sum(f.stat().st_size for f in first.rglob("*") if f.is_file())
    monkeypatch.setenv("FMIONNX_CACHE_MAX_BYTES", str(int(2.5 * entry_bytes)))
    _age(first, 2 * IN_USE_SECONDS)
    _age(second, 3 * IN_USE_SECONDS)
    third = unpack_ssp(_ssp(tmp_path / "third.ssp", gain_fmu, "third"))
    assert third.is_dir()
    assert first.is_dir()
    assert not second.exists()


def test_entries_in_use_and_the_current_one_are_never_evicted(tmp_path: Path) -> None:
    root = tmp_path / "cache-root"
    busy, current = root / "busy", root / "current"
    for entry in (busy, current):
        entry.mkdir(parents=True)
        (entry / "data").write_bytes(bytes(1000))
    assert evict(root, keep=current, max_bytes=10, max_days=30) == []
    assert busy.is_dir()
    assert current.is_dir()


def test_work_folders_of_dead_processes_are_removed(tmp_path: Path, gain_fmu: Path) -> None:
    root = cache_root()
    root.mkdir(parents=True)
    dead = root / ".unpack-999999999-abc"  # no process has this id
    (dead / "resources").mkdir(parents=True)
    fresh = root / ".unpack-999999998-abc"  # may be a live process in another PID namespace
    fresh.mkdir()
    _age(dead, 2 * IN_USE_SECONDS)
    unpack_ssp(_ssp(tmp_path / "any.ssp", gain_fmu, "any"))
    assert not dead.exists()
    assert fresh.is_dir()
