"""Where fmionnx keeps what it can make again: one rule for every cache folder, and eviction.

``$FMIONNX_CACHE/<name>`` when set, else ``$XDG_CACHE_HOME/fmionnx/<name>``, else
``~/.cache/fmionnx/<name>``: unpacked SSPs and the opt-in run-time kernel build live there.

A cache of unpacked archives grows with every archive a user ever opened, so it is bounded
(:func:`evict`): entries unused for longer than a number of days go, and beyond a total size
the least recently used go first. "Used" is the entry folder's modification time, which the
owner touches on every use (:func:`touch`). Entries used in the last few minutes are never
evicted, since another process may be running from them right now; the bound can be exceeded
by what is in use at once. Eviction renames an entry out of the way before deleting it, so
no process ever sees half an entry, and it runs under a lock file so two processes do not
race. Hidden folders of a process that died mid-unpack (``.unpack-<pid>-…``) are removed too,
once untouched for the same minutes.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

#: An entry used this recently is never evicted (another process may be running from it).
IN_USE_SECONDS = 10 * 60
#: Hidden work folders: ``.unpack-<pid>-…`` while unpacking, ``.evict-<pid>-…`` while deleting.
_WORK = re.compile(r"\.(?:unpack|evict)-(\d+)-")


def cache_folder(name: str) -> Path:
    """The cache folder called ``name`` (not created here)."""
    explicit = os.environ.get("FMIONNX_CACHE")
    if explicit:
        return Path(explicit).expanduser() / name
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "fmionnx" / name


def touch(entry: Path) -> None:
    """Record that ``entry`` was used now (its place in the least-recently-used order)."""
    with contextlib.suppress(OSError):
        os.utime(entry)


def work_prefix(kind: str) -> str:
    """Prefix of a hidden work folder of this process (``.unpack-<pid>-``)."""
    return f".{kind}-{os.getpid()}-"


@dataclass(frozen=True, slots=True)
class _Entry:
    path: Path
    used: float
    size: int


def _size(folder: Path) -> int:
    total = 0
    for root, _, files in os.walk(folder):
        for name in files:
            with contextlib.suppress(OSError):
                total += (Path(root) / name).lstat().st_size
    return total


def _pid_gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    return False


def _abandoned_work(folder: Path, pid: int, now: float) -> bool:
    """A work folder whose process is gone: no such process id, and untouched for longer than
    any unpack takes (the id alone could name a live process in another PID namespace)."""
    try:
        idle = now - folder.lstat().st_mtime
    except OSError:
        return False
    return folder.is_dir() and idle > IN_USE_SECONDS and _pid_gone(pid)


@contextlib.contextmanager
def _locked(root: Path) -> Iterator[None]:
    """Hold the cache's lock file (opened without following a link planted at its name)."""
    handle = os.open(root / ".lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield
    finally:
        os.close(handle)  # releases the lock


def _remove(entry: Path) -> None:
    doomed = entry.with_name(f"{work_prefix('evict')}{entry.name}")
    try:
        entry.rename(doomed)
    except OSError:
        return
    shutil.rmtree(doomed, ignore_errors=True)


def discard(entry: Path) -> None:
    """Remove one entry now (renamed out of the way first: no process sees half of it)."""
    _remove(entry)


def evict(root: Path, *, keep: Path, max_bytes: int, max_days: int) -> list[Path]:
    """Bound the cache at ``root``: remove entries unused for ``max_days``, then the least
    recently used until the rest fits in ``max_bytes``. ``keep`` (the entry in use by the
    caller) and entries used in the last minutes stay. Returns what was removed."""
    if not root.is_dir():
        return []
    removed: list[Path] = []
    now = time.time()
    with _locked(root):
        entries: list[_Entry] = []
        for child in root.iterdir():
            work = _WORK.match(child.name)
            if work is not None:
                if _abandoned_work(child, int(work[1]), now):
                    shutil.rmtree(child, ignore_errors=True)
                continue
            if child.name.startswith(".") or not child.is_dir() or child.is_symlink():
                continue
            if child.resolve() == keep.resolve():
                continue
            with contextlib.suppress(OSError):
                entries.append(_Entry(child, child.stat().st_mtime, _size(child)))
        total = _size(keep) + sum(e.size for e in entries)
        for entry in sorted(entries, key=lambda e: e.used):
            too_old = now - entry.used > max_days * 86400
            too_big = total > max_bytes and now - entry.used > IN_USE_SECONDS
            if too_old or too_big:
                _remove(entry.path)
                removed.append(entry.path)
                total -= entry.size
    return removed
