"""Temporary extraction folders that do not outlive the process that made them.

An FMU is unpacked for every run (its shared library must be a file to be loaded) and a source
FMU is unpacked to be built. Each such folder is removed when its user is done, and on any
exit of the interpreter (normal end, an exception, ``sys.exit``, SIGTERM/SIGHUP handled by
:mod:`fmionnx.runtime.stopping`) by an ``atexit`` hook. A process that dies without running
Python's exit (SIGKILL, a native crash or ``abort()`` inside an FMU) cannot clean up after
itself, so the next fmionnx process that makes a scratch folder removes the folders whose
owner is gone.

Who owns a folder is told by a lock, not by a process id: each folder holds a file
(:data:`OWNER_FILE`) its process keeps locked (``flock``) for as long as the folder is in use.
The kernel drops the lock when the process dies, however it dies, and a lock is seen across
PID namespaces (containers sharing ``/tmp``), where a process id would name someone else. The
folder's name, ``fmionnx-<pid>-<label>-<random>``, still carries the process id for people
looking at ``/tmp``, and for a folder without the file (a process killed between making the
folder and locking it) the id decides, after a minute of grace. Only folders of the current
user and of that exact name form are touched.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

#: ``fmionnx-<pid>-`` starts every scratch folder's name.
PREFIX = "fmionnx-"
#: The file inside each scratch folder that its process keeps locked.
OWNER_FILE = ".fmionnx-owner"
#: A folder without an owner file younger than this may be being made right now.
GRACE_SECONDS = 60

_OWNED = re.compile(rf"{PREFIX}(\d+)-")
#: Folders made here: the open, locked owner file of each and the id of the process that made
#: it (a child forked from this process must not remove its parent's folders at its exit).
_LIVE: dict[Path, tuple[int, int]] = {}
#: Holds ``True`` once this process has swept the folders of dead processes.
_SWEPT: list[bool] = []


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive, and not ours anyway
        return True
    return True


def _abandoned(folder: Path, pid: int) -> bool:
    """True when no process holds ``folder``'s owner lock any more."""
    try:
        handle = os.open(folder / OWNER_FILE, os.O_RDONLY | os.O_NOFOLLOW)
    except FileNotFoundError:
        young = time.time() - folder.lstat().st_mtime < GRACE_SECONDS
        return not young and not _pid_alive(pid)
    except OSError:
        return False
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    finally:
        os.close(handle)
    return True


def sweep_stale(parent: Path | None = None) -> list[Path]:
    """Remove scratch folders whose process is gone; return them."""
    base = Path(parent or tempfile.gettempdir())
    removed: list[Path] = []
    try:
        entries = list(base.iterdir())
    except OSError:
        return removed
    uid = os.getuid()
    for entry in entries:
        match = _OWNED.match(entry.name)
        if match is None or entry in _LIVE:
            continue
        try:
            info = entry.lstat()
            if entry.is_symlink() or not entry.is_dir() or info.st_uid != uid:
                continue
            if _abandoned(entry, int(match[1])):
                shutil.rmtree(entry, ignore_errors=True)
                removed.append(entry)
        except OSError:
            continue
    return removed


def make_scratch(label: str) -> Path:
    """A new folder for ``label`` (a component name, ``build``), removed at exit.

    It holds only the owner file; the first call of a process also sweeps the folders of
    processes that are gone.
    """
    if not _SWEPT:
        _SWEPT.append(True)
        sweep_stale()
    safe = re.sub(r"[^\w.]", "_", label)[:40]
    folder = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{os.getpid()}-{safe}-"))
    handle = os.open(folder / OWNER_FILE, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
    fcntl.flock(handle, fcntl.LOCK_EX)
    _LIVE[folder] = (handle, os.getpid())
    return folder


def remove_scratch(folder: Path) -> None:
    """Remove a folder made by :func:`make_scratch` (again is harmless)."""
    owner = _LIVE.pop(folder, None)
    if owner is not None:
        os.close(owner[0])  # releases the lock
    shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def scratch(label: str) -> Iterator[Path]:
    """A scratch folder for the ``with`` block."""
    folder = make_scratch(label)
    try:
        yield folder
    finally:
        remove_scratch(folder)


@atexit.register
def _remove_all() -> None:
    """Whatever a runner or build did not remove itself (a fault, an exit mid-run)."""
    for folder, (_, pid) in list(_LIVE.items()):
        if pid == os.getpid():
            remove_scratch(folder)
