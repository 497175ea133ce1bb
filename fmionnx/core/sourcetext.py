"""Cached access to the lines of source files, for excerpts and column fix-ups; and the texts
of files being edited, which stand in for what is on disk while they are.

An editor's language server (``fmionnx lsp``) checks a system file as it is typed, before it
is saved: :func:`editing` makes the buffers' texts what every reader of a source file sees
(the YAML front end, the study loader, the SSD parser, and :func:`source_lines` that places
columns), so the compiler runs unchanged on unsaved text. The texts are held in a context
variable: they apply to the code run inside the ``with`` block, in that thread, and nowhere
else.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType

#: Nothing edited: the default (immutable, shared by every context).
_NOTHING: Mapping[Path, str] = MappingProxyType({})
_EDITED: ContextVar[Mapping[Path, str]] = ContextVar("fmionnx_edited_texts", default=_NOTHING)


def _key(path: Path) -> Path:
    """The name a file is known by here: absolute, links resolved (as far as they exist)."""
    return path.resolve()


@contextlib.contextmanager
def editing(texts: Mapping[Path, str]) -> Iterator[None]:
    """Within the block, the file at each path of ``texts`` reads as that text."""
    resolved = {_key(path): text for path, text in texts.items()}
    token = _EDITED.set({**_EDITED.get(), **resolved})
    try:
        yield
    finally:
        _EDITED.reset(token)


def editing_any() -> bool:
    """Whether some file is being edited (inside :func:`editing`): what is on disk is then
    not what is read, so nothing read may be taken from a cache of the files on disk."""
    return bool(_EDITED.get())


def edited_text(path: Path) -> str | None:
    """The text of ``path`` when it is being edited (inside :func:`editing`), else None."""
    texts = _EDITED.get()
    if not texts:
        return None
    try:
        return texts.get(_key(path))
    except (OSError, RuntimeError):  # a name too long, a loop of links: not an edited file
        return None


def source_lines(path: Path) -> tuple[str, ...]:
    """The lines of a UTF-8 text file; empty when it cannot be read.

    Cached by absolute path, modification time and size, so a file edited (or a relative
    path seen from another working directory) is read afresh. (Not resolved: resolving
    every component's links cost a compile of 400 000 connections a minute.) A file being
    edited (:func:`editing`) gives the lines of its text.
    """
    edited = edited_text(path)
    if edited is not None:
        return _split(edited)
    try:
        resolved = path.absolute()
        stat = resolved.stat()
    except OSError:
        return ()
    return _read(resolved, stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=16)
def _split(text: str) -> tuple[str, ...]:
    return tuple(text.splitlines())


@lru_cache(maxsize=64)
def _read(path: Path, mtime_ns: int, size: int) -> tuple[str, ...]:
    del mtime_ns, size  # part of the cache key only
    try:
        return tuple(path.read_text(encoding="utf-8").splitlines())
    except (OSError, UnicodeDecodeError):
        return ()
