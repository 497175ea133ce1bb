"""Shared-memory segments a killed Zenoh process leaves behind, removed.

zenoh-python moves large payloads between processes of one host through POSIX shared memory
(``/dev/shm/<id>.zenoh``). A process that exits normally removes its segments; one that is
killed (SIGKILL, the out-of-memory killer, a node whose supervisor died) leaves them there
until the host reboots: megabytes per node and run (zenoh-c #245, rmw_zenoh #224). Every
process that uses a segment, writer and readers, holds a shared ``flock`` on its file, so a
segment no process holds is orphaned: an exclusive lock taken without waiting proves it, and
only then is it removed. The supervisor of a Zenoh run removes the orphans it finds when the
run ends (its nodes have exited then, killed or not), which also takes those of an earlier run
that was killed as a whole.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
from pathlib import Path

#: Where POSIX shared memory lives on Linux.
SHM_FOLDER = Path("/dev/shm")
#: The file name ending of Zenoh's segments.
SUFFIX = ".zenoh"

LOG = logging.getLogger(__name__)


def remove_orphaned_segments(folder: Path = SHM_FOLDER) -> int:
    """Remove this user's Zenoh segments in ``folder`` that no process holds; how many."""
    removed = 0
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return 0
    uid = os.getuid()
    for entry in entries:
        if not entry.name.endswith(SUFFIX):
            continue
        with contextlib.suppress(OSError):
            if entry.is_symlink() or not entry.is_file() or entry.stat().st_uid != uid:
                continue
            if _orphaned(Path(entry.path)):
                Path(entry.path).unlink()
                removed += 1
    if removed:
        LOG.info("removed %d shared-memory segment(s) that killed Zenoh processes left", removed)
    return removed


def _orphaned(path: Path) -> bool:
    """Whether no process holds ``path`` (an exclusive lock is granted at once)."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        return True
    finally:
        os.close(fd)  # the lock goes with the descriptor
