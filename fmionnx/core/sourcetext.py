"""Cached access to the lines of source files, for excerpts and column fix-ups."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path


def source_lines(path: Path) -> tuple[str, ...]:
    """The lines of a UTF-8 text file; empty when it cannot be read.

    Cached by absolute path, modification time and size, so a file edited (or a relative
    path seen from another working directory) is read afresh. (Not resolved: resolving
    every component's links cost a compile of 400 000 connections a minute.)
    """
    try:
        resolved = path.absolute()
        stat = resolved.stat()
    except OSError:
        return ()
    return _read(resolved, stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=64)
def _read(path: Path, mtime_ns: int, size: int) -> tuple[str, ...]:
    del mtime_ns, size  # part of the cache key only
    try:
        return tuple(path.read_text(encoding="utf-8").splitlines())
    except (OSError, UnicodeDecodeError):
        return ()
