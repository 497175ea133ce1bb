"""Shared-memory segments of killed Zenoh processes are removed; segments in use never are.

A Zenoh process holds a shared ``flock`` on every segment it uses; a killed one leaves its
segments in ``/dev/shm`` unheld (issue #38: 8 files, 17 MB after a killed run). The rule is
tested on a folder of the test's own, with a segment held by another process, one left by a
process that died, and files that are not Zenoh's own.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from fmionnx.backends.ros2.zenoh.shm import remove_orphaned_segments

HOLD = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDONLY)
fcntl.flock(fd, fcntl.LOCK_SH)
print("held", flush=True)
time.sleep(60)
"""


def test_only_segments_no_process_holds_are_removed(tmp_path: Path) -> None:
    orphan, held = tmp_path / "1284722244.zenoh", tmp_path / "62115.zenoh"
    other, outside = tmp_path / "psm_1234", tmp_path / "outside.txt"
    for path in (orphan, held, other, outside):
        path.write_bytes(b"\0" * 4096)
    (tmp_path / "777.zenoh").symlink_to(outside)  # never followed, never removed
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(held)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None
        assert holder.stdout.readline().strip() == "held"
        assert remove_orphaned_segments(tmp_path) == 1
        assert sorted(p.name for p in tmp_path.iterdir()) == [
            "62115.zenoh", "777.zenoh", "outside.txt", "psm_1234",
        ]  # fmt: skip
    finally:
        holder.kill()
        holder.communicate(timeout=30)
    assert remove_orphaned_segments(tmp_path) == 1  # its holder is gone now
    assert not held.exists()
    assert outside.exists()


def test_a_missing_folder_removes_nothing(tmp_path: Path) -> None:
    assert remove_orphaned_segments(tmp_path / "none") == 0


@pytest.mark.ros2
def test_a_killed_publisher_leaves_segments_the_cleanup_removes(tmp_path: Path) -> None:
    """A real Zenoh peer publishing frames through shared memory, killed: its segments stay
    in /dev/shm until the cleanup, which removes exactly those."""
    shm = Path("/dev/shm")
    if not shm.is_dir():
        pytest.skip("no /dev/shm")
    before = {p.name for p in shm.glob("*.zenoh")}
    code = (
        "import os, time, zenoh\n"
        "c = zenoh.Config()\n"
        "c.insert_json5('scouting/multicast/enabled', 'false')\n"
        "s = zenoh.open(c)\n"
        "p = s.declare_publisher('fmionnx/test/shm')\n"
        "for i in range(5):\n"
        "    p.put(b'x' * 200000)\n"
        "print('published', flush=True)\n"
        "time.sleep(60)\n"
    )
    peer = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert peer.stdout is not None
    assert peer.stdout.readline().strip() == "published"
    peer.kill()
    peer.communicate(timeout=30)
    deadline = time.monotonic() + 10
    left = {p.name for p in shm.glob("*.zenoh")} - before
    while not left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = {p.name for p in shm.glob("*.zenoh")} - before
    if not left:
        pytest.skip("this zenoh build made no shared-memory segment")
    remove_orphaned_segments()
    assert not any((shm / name).exists() for name in left)
