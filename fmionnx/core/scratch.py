"""Temporary extraction folders that do not outlive the process that made them.

An FMU is unpacked for every run (its shared library must be a file to be loaded) and a source
FMU is unpacked to be built. Each such folder is removed when its user is done, and on any
exit of the interpreter (normal end, an exception, ``sys.exit``, SIGTERM/SIGHUP handled by
:mod:`fmionnx.runtime.stopping`) by an ``atexit`` hook. A process that dies without running
Python's exit (SIGKILL, a native crash or ``abort()`` inside an FMU) cannot clean up after
itself, so its folders carry its process id, ``fmionnx-<pid>-<label>-<random>``, and the next
fmionnx process that makes a scratch folder removes every such folder whose process is gone.
Only folders of the current user and of that exact name form are touched.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

#: ``fmionnx-<pid>-`` starts every scratch folder's name.
PREFIX = "fmionnx-"
_OWNED = re.compile(rf"{PREFIX}(\d+)-")

_LIVE: set[Path] = set()
#: Holds ``True`` once this process has swept the folders of dead processes.
_SWEPT: list[bool] = []


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive, and not ours anyway
        return True
    return True


def sweep_stale(parent: Path | None = None) -> list[Path]:
    """Remove scratch folders left by fmionnx processes that no longer exist; return them."""
    base = Path(parent or tempfile.gettempdir())
    removed: list[Path] = []
    try:
        entries = list(base.iterdir())
    except OSError:
        return removed
    uid = os.getuid()
    for entry in entries:
        match = _OWNED.match(entry.name)
        if match is None or int(match[1]) == os.getpid():
            continue
        try:
            info = entry.lstat()
        except OSError:
            continue
        if not entry.is_dir() or entry.is_symlink() or info.st_uid != uid:
            continue
        if not _alive(int(match[1])):
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def make_scratch(label: str) -> Path:
    """A new empty folder for ``label`` (a component name, ``build``), removed at exit.

    The first call of a process also sweeps the folders of dead fmionnx processes.
    """
    if not _SWEPT:
        _SWEPT.append(True)
        sweep_stale()
    safe = re.sub(r"[^\w.]", "_", label)[:40]
    folder = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{os.getpid()}-{safe}-"))
    _LIVE.add(folder)
    return folder


def remove_scratch(folder: Path) -> None:
    """Remove a folder made by :func:`make_scratch` (again is harmless)."""
    _LIVE.discard(folder)
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
    for folder in list(_LIVE):
        remove_scratch(folder)
