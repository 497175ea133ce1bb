"""Named semaphores of a study killed outright are removed by the next local cluster; those a
live process maps, young ones, other names and other users' files stay."""

from __future__ import annotations

import mmap
import os
import time
from pathlib import Path

import pytest

from fmionnx.backends.sweep.leftovers import GRACE_SECONDS, sweep_orphan_semaphores


def _semaphore(shm: Path, name: str, age: float) -> Path:
    path = shm / name
    path.write_bytes(bytes(32))
    then = time.time() - age
    os.utime(path, (then, then))
    return path


def test_only_old_unmapped_semaphores_of_the_users_name_form_are_removed(tmp_path: Path) -> None:
    shm = tmp_path / "shm"
    shm.mkdir()
    old = GRACE_SECONDS + 5
    orphan = _semaphore(shm, "sem.mp-orphan1", old)
    in_use = _semaphore(shm, "sem.mp-inuse22", old)
    young = _semaphore(shm, "sem.mp-young33", 0)
    other_name = _semaphore(shm, "sem.mine", old)
    with in_use.open("r+b") as handle, mmap.mmap(handle.fileno(), 32):
        removed = sweep_orphan_semaphores(shm)
    assert removed == [orphan]
    assert sorted(p.name for p in shm.iterdir()) == sorted(
        p.name for p in (in_use, young, other_name)
    )


def test_a_semaphore_in_any_readable_map_stays_and_an_unreadable_map_is_passed_over(
    tmp_path: Path,
) -> None:
    shm = tmp_path / "shm"
    shm.mkdir()
    orphan = _semaphore(shm, "sem.mp-orphan1", GRACE_SECONDS + 5)
    held = _semaphore(shm, "sem.mp-held444", GRACE_SECONDS + 5)
    proc = tmp_path / "proc"
    (proc / "4242").mkdir(parents=True)
    (proc / "4242" / "maps").mkdir()  # reading it fails as a map one may not read does
    (proc / "4343").mkdir()
    (proc / "4343" / "maps").write_text(
        f"7f0000000000-7f0000001000 rw-s 00000000 00:1a 99  {held} (deleted)\n", "utf-8"
    )
    assert sweep_orphan_semaphores(shm, proc) == [orphan]
    assert held.exists()


def test_no_proc_no_removal(tmp_path: Path) -> None:
    shm = tmp_path / "shm"
    shm.mkdir()
    orphan = _semaphore(shm, "sem.mp-orphan1", GRACE_SECONDS + 5)
    assert sweep_orphan_semaphores(shm, tmp_path / "no-proc") == []
    assert orphan.exists()


def test_a_semaphore_unlinked_during_the_scan_is_passed_over_and_the_rest_removed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another study's resource tracker unlinks its semaphores at any moment: one gone
    between listing the folder and looking at it made the whole clean-up give up (a killed
    study's leftovers stayed: seen in a full suite, where studies run side by side)."""
    shm = tmp_path / "shm"
    shm.mkdir()
    gone = _semaphore(shm, "sem.mp-gone5555", GRACE_SECONDS + 5)
    orphan = _semaphore(shm, "sem.mp-orphan1", GRACE_SECONDS + 5)
    lstat = Path.lstat

    def unlinked_meanwhile(self: Path) -> os.stat_result:
        if self.name == gone.name:
            self.unlink()  # the other study's tracker, between the listing and this look
        return lstat(self)

    monkeypatch.setattr(Path, "lstat", unlinked_meanwhile)
    assert sweep_orphan_semaphores(shm) == [orphan]
    assert list(shm.iterdir()) == []
