"""Named semaphores a killed study left in ``/dev/shm``.

Dask's nanny starts each worker with multiprocessing's *spawn* method, and a semaphore made
under that method is a named POSIX semaphore (``/dev/shm/sem.mp-…``) that stays until
multiprocessing's resource tracker unlinks it at the end. A study stopped by SIGKILL (an
out-of-memory killer, ``kill -9`` on its process group, a CI job's timeout) takes the tracker
with it, and the files stay until the machine restarts: a few hundred bytes each, but one set
per killed study, in a file system that lives in memory.

So a local cluster, before it starts, removes the semaphores that are the current user's,
older than a minute and mapped by no process (``sem_open`` maps the file, so a semaphore in use
shows in its users' ``/proc/<pid>/maps``; its creator maps the temporary file it made it from,
under another name, so a new semaphore looks unused until the worker it was made for opens it:
the minute covers that). Only that exact name form is touched. A process
whose map the user may not read although it runs as the user (a container's init, a process
that made itself non-dumpable) is not a multiprocessing program and is passed over; if
``/proc`` itself cannot be read, nothing is removed.
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

#: Where glibc keeps named semaphores.
SHM = Path("/dev/shm")
#: A semaphore younger than this may be being opened right now.
GRACE_SECONDS = 60

_NAME = re.compile(r"sem\.mp-[A-Za-z0-9_]+")


def _mapped(proc: Path, shm: Path, uid: int) -> set[str]:
    """The names of the files in ``shm`` this user's processes map."""
    prefix = f"{shm}/"
    found: set[str] = set()
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if entry.stat().st_uid != uid:
                continue  # another user's process cannot open this user's 0600 semaphores
            text = (entry / "maps").read_text(errors="replace")
        except OSError:
            continue  # ended while we looked, or not readable (see the module's docstring)
        for line in text.splitlines():
            position = line.find(prefix)
            if position >= 0:
                found.add(line[position + len(prefix) :].removesuffix(" (deleted)"))
    return found


def sweep_orphan_semaphores(shm: Path = SHM, proc: Path = Path("/proc")) -> list[Path]:
    """Remove this user's multiprocessing semaphores in ``shm`` that no process maps; return
    them."""
    uid = os.getuid()
    now = time.time()
    candidates: list[Path] = []
    try:
        entries = list(shm.iterdir())
    except OSError:
        return []
    for entry in entries:
        if not _NAME.fullmatch(entry.name):
            continue
        try:
            info = entry.lstat()
        except OSError:  # unlinked meanwhile (another study's tracker): not a leftover
            continue
        if info.st_uid == uid and now - info.st_mtime >= GRACE_SECONDS:
            candidates.append(entry)
    if not candidates:
        return []
    try:
        in_use = _mapped(proc, shm, uid)
    except OSError:
        return []
    removed: list[Path] = []
    for entry in candidates:
        if entry.name in in_use:
            continue
        try:
            entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    return removed
