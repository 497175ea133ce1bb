"""Cached access to the lines of source files, for excerpts and column fix-ups."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path


@lru_cache(maxsize=64)
def source_lines(path: Path) -> tuple[str, ...]:
    """The lines of a UTF-8 text file; empty when it cannot be read."""
    try:
        return tuple(path.read_text(encoding="utf-8").splitlines())
    except (OSError, UnicodeDecodeError):
        return ()
