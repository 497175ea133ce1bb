"""Writing files without losing the user's data.

Every file fmionnx writes into a folder the user chose (results, run.json, plots, lock files,
converted systems) goes through here, for two reasons:

* **atomic**: the text is written to a temporary file in the same folder and then renamed over
  the name, so a crash, a full disk or Ctrl-C never leaves a half-written file behind;
* **no symlink is followed**: ``os.replace`` replaces a symbolic link planted at the name
  *itself*, never the file it points to, so a link ``out/run.json -> ~/.bashrc`` cannot make a
  run overwrite something outside its folder.

:class:`OverwriteRefusedError` is what the writers raise when a name already holds something
fmionnx did not write; the command line turns it into a usage error naming ``--force``.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from fmionnx.core.errors import FmionnxError


class OverwriteRefusedError(FmionnxError):
    """A command would replace or delete something it did not write (``--force`` allows it)."""


def refuse(path: Path, what: str, option: str = "--force") -> OverwriteRefusedError:
    """The error for ``path`` (``what`` says why it is not ours); nothing was written."""
    msg = f"`{path}` {what}; not replacing it (use {option} to replace it)"
    return OverwriteRefusedError(msg)


@contextlib.contextmanager
def atomic_text(path: Path) -> Iterator[IO[str]]:
    """A text stream whose content appears at ``path`` only when the ``with`` block succeeds."""
    with _temporary(path) as temporary, temporary.open("w", encoding="utf-8", newline="\n") as s:
        yield s


@contextlib.contextmanager
def atomic_binary(path: Path) -> Iterator[IO[bytes]]:
    """A binary stream whose content appears at ``path`` only when the block succeeds."""
    with _temporary(path) as temporary, temporary.open("wb") as stream:
        yield stream


@contextlib.contextmanager
def _temporary(path: Path) -> Iterator[Path]:
    """A fresh file beside ``path``, renamed over it after the block (removed on failure).

    A folder at ``path`` is an error (``IsADirectoryError``), not something to replace.
    """
    if path.is_dir() and not path.is_symlink():
        msg = f"`{path}` is a folder"
        raise IsADirectoryError(msg)
    descriptor, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    os.close(descriptor)
    temporary = Path(name)
    try:
        yield temporary
        temporary.chmod(0o644)  # mkstemp makes 0600; results are ordinary readable files
        temporary.replace(path)  # replaces a link at ``path`` itself, not its target
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically, never through a link."""
    with atomic_text(path) as stream:
        stream.write(text)
    return path


def write_bytes_atomic(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically, never through a symbolic link."""
    with atomic_binary(path) as stream:
        stream.write(data)
    return path


def open_growing(path: Path) -> IO[bytes]:
    """A binary stream at ``path`` for a file that grows while a run goes on (a node's log, a
    topic recording), readable under its name all along, and never written through a link.

    A symbolic link planted at ``path`` is removed (not followed); ``O_NOFOLLOW`` refuses one
    planted between that and the open.
    """
    if path.is_symlink():
        path.unlink()
    flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW | os.O_CLOEXEC
    return os.fdopen(os.open(path, flags, 0o644), "wb")
