"""Output folders: fmionnx deletes only what it can prove it wrote.

A results folder (``run --out``, ``sweep --out``) is a folder of the user's file system that
fmionnx writes into again and again: a new run replaces the files of the last one and removes
those it does not write again, ``sweep --force`` starts a study afresh. What fmionnx may
delete there must not depend on a file anybody could have written -- a ``run.json`` listing
``thesis.txt``, a ``study.json`` in a folder of documents -- nor reach outside the folder or
through a link.

The proof is the folder's *ownership record*, ``.fmionnx-owned``: one line of JSON per file
fmionnx wrote there (appended when the file is complete), naming it inside the folder and
saying which file it was -- device, inode, size and modification time (ns). A file is
fmionnx's when a line names it *and* the file now at that name is a regular file with exactly
that identity: a file the user edited, replaced or put there, or a record copied from
elsewhere (another inode), proves nothing, and a forged record can only name files that are
already fmionnx's. Deleting walks the name one folder at a time, never following a link, and
checks the identity on the very file it unlinks.

What is not proven is left alone, ``--force`` or not: ``--force`` lets fmionnx *write* into a
folder it does not own, never delete what it did not write.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from fmionnx.core.regularfile import read_head
from fmionnx.core.safewrite import write_text_atomic

#: The ownership record's name in the folder it describes.
MARKER = ".fmionnx-owned"
#: Its first line.
HEADER = {"format": "fmionnx-owned", "version": 1}
#: A record larger than this is not read (it proves nothing: no run writes that many files).
MAX_MARKER_BYTES = 256 * 1024**2
#: A line longer than this is not an entry (names are bounded by the file system anyway).
MAX_LINE_BYTES = 8192


@dataclass(frozen=True, slots=True)
class Entry:
    """One file fmionnx wrote: its name in the folder and which file it was."""

    name: str
    device: int
    inode: int
    size: int
    mtime_ns: int

    def matches(self, found: os.stat_result) -> bool:
        """Whether ``found`` (an ``lstat``) is this very file, unchanged."""
        return stat.S_ISREG(found.st_mode) and (
            found.st_dev,
            found.st_ino,
            found.st_size,
            found.st_mtime_ns,
        ) == (self.device, self.inode, self.size, self.mtime_ns)


def plain_name(name: object) -> PurePosixPath | None:
    """``name`` as a relative path inside a folder, or None when it could lead elsewhere
    (absolute, ``..``, ``.``, empty parts, backslashes, NUL)."""
    if not isinstance(name, str) or not name or "\\" in name or "\0" in name:
        return None
    path = PurePosixPath(name)
    if path.is_absolute() or any(part in ("", ".", "..") for part in name.split("/")):
        return None
    return path


@contextlib.contextmanager
def _parent(root: Path, name: PurePosixPath, *, create: bool = False) -> Iterator[int]:
    """A descriptor of the folder ``name`` lies in, reached from ``root`` one folder at a
    time without following a link inside ``root`` (``create``: making missing folders);
    OSError when a part is a link, not a folder, or missing. ``root`` itself is the folder
    the user named, a link or not."""
    flags = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
    fd = os.open(root, flags & ~os.O_NOFOLLOW)  # the folder as the user named it
    try:
        for part in name.parts[:-1]:
            if create:
                with contextlib.suppress(FileExistsError):
                    os.mkdir(part, 0o777, dir_fd=fd)
            inner = os.open(part, flags, dir_fd=fd)
            os.close(fd)
            fd = inner
        yield fd
    finally:
        os.close(fd)


class OwnedFolder:
    """An output folder and its ownership record."""

    def __init__(self, root: Path) -> None:
        self.root = root

    @property
    def marker(self) -> Path:
        """The ownership record."""
        return self.root / MARKER

    # -- reading the record ---------------------------------------------------------------------

    def claimed(self) -> bool:
        """Whether the folder holds an ownership record (a regular file, not a link, whose
        first line is fmionnx's). It proves nothing by itself: see :meth:`proven`."""
        return self._lines() is not None

    def _lines(self) -> list[bytes] | None:
        try:
            with _parent(self.root, PurePosixPath(MARKER)) as folder:
                data = read_head(MARKER, MAX_MARKER_BYTES + 1, follow=False, dir_fd=folder)
        except OSError:
            return None
        if data is None or len(data) > MAX_MARKER_BYTES:
            return None  # a folder, a FIFO or a device so named; or too large to be ours
        lines = data.split(b"\n")
        try:
            header = json.loads(lines[0])
        except ValueError:
            return None
        return lines[1:] if header == HEADER else None

    def entries(self) -> list[Entry]:
        """Every well-formed entry of the record (the last one of a name counts)."""
        found: dict[str, Entry] = {}
        for line in self._lines() or []:
            if not line or len(line) > MAX_LINE_BYTES:
                continue  # a torn last line (a crash while appending), or junk
            try:
                data = json.loads(line)
                entry = Entry(
                    str(data["name"]), int(data["device"]), int(data["inode"]),
                    int(data["size"]), int(data["mtime_ns"]),
                )  # fmt: skip
            except (ValueError, KeyError, TypeError):
                continue
            if plain_name(entry.name) is not None:
                found[entry.name] = entry
        return list(found.values())

    def _lstat(self, name: str) -> os.stat_result | None:
        path = plain_name(name)
        if path is None:
            return None
        try:
            with _parent(self.root, path) as folder:
                return os.stat(path.name, dir_fd=folder, follow_symlinks=False)
        except OSError:
            return None

    def proven(self, name: str) -> bool:
        """Whether the file at ``name`` is one fmionnx wrote here, unchanged."""
        entry = next((e for e in self.entries() if e.name == name), None)
        found = self._lstat(name)
        return entry is not None and found is not None and entry.matches(found)

    def proven_names(self) -> set[str]:
        """The names of every file of the folder fmionnx can prove it wrote."""
        return {
            e.name
            for e in self.entries()
            if (found := self._lstat(e.name)) is not None and e.matches(found)
        }

    # -- writing the record ---------------------------------------------------------------------

    def _entry(self, path: Path) -> str | None:
        """The record line of ``path`` (a file just written in the folder), or None when it
        is not a regular file inside the folder."""
        name = self.name_of(path)
        found = self._lstat(name) if name is not None else None
        if name is None or found is None or not stat.S_ISREG(found.st_mode):
            return None
        data = {
            "name": name, "device": found.st_dev, "inode": found.st_ino,
            "size": found.st_size, "mtime_ns": found.st_mtime_ns,
        }  # fmt: skip
        return json.dumps(data, separators=(",", ":"))

    def name_of(self, path: Path) -> str | None:
        """``path``'s name inside the folder (POSIX), or None when it lies elsewhere."""
        try:
            relative = (path.parent.resolve() / path.name).relative_to(self.root.resolve())
        except (ValueError, OSError):
            return None
        name = relative.as_posix()
        return name if plain_name(name) is not None else None

    def note(self, paths: Iterable[Path]) -> None:
        """Add the files just written at ``paths`` to the record (appended: a study notes
        each record as it finishes, without rewriting the whole record)."""
        lines = [line for path in paths if (line := self._entry(path)) is not None]
        if not lines:
            return
        if not self.claimed():
            self.record([])
        flags = os.O_WRONLY | os.O_APPEND | os.O_NOFOLLOW | os.O_CLOEXEC
        with _parent(self.root, PurePosixPath(MARKER)) as folder:
            fd = os.open(MARKER, flags, dir_fd=folder)
        with os.fdopen(fd, "ab") as stream:
            stream.write(("\n".join(lines) + "\n").encode())  # one write: lines never interleave

    def record(self, paths: Iterable[Path]) -> None:
        """Make the record list exactly the files at ``paths`` (written atomically)."""
        lines = [line for path in paths if (line := self._entry(path)) is not None]
        text = "\n".join([json.dumps(HEADER, separators=(",", ":")), *lines]) + "\n"
        write_text_atomic(self.marker, text)

    # -- deleting -------------------------------------------------------------------------------

    def remove(self, names: Iterable[str]) -> list[str]:
        """Delete those of ``names`` fmionnx can prove it wrote (nothing else: a name that
        is not proven, lies elsewhere, or is reached through a link is skipped); returns the
        names deleted. A folder left empty by the deletions is removed too (``rmdir``: only
        when empty, and never the folder itself)."""
        wanted = set(names)
        removed: list[str] = []
        for entry in self.entries():
            path = plain_name(entry.name)
            if entry.name not in wanted or path is None:
                continue
            try:
                with _parent(self.root, path) as folder:
                    found = os.stat(path.name, dir_fd=folder, follow_symlinks=False)
                    if not entry.matches(found):
                        continue
                    os.unlink(path.name, dir_fd=folder)
            except OSError:
                continue
            removed.append(entry.name)
        self._remove_empty_folders(removed)
        return removed

    def remove_all(self) -> list[str]:
        """Delete every file fmionnx can prove it wrote here (see :meth:`remove`)."""
        return self.remove(e.name for e in self.entries())

    def _remove_empty_folders(self, removed: list[str]) -> None:
        folders = {
            parent
            for name in removed
            for parent in PurePosixPath(name).parents
            if parent != PurePosixPath(".")
        }
        for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
            with contextlib.suppress(OSError), _parent(self.root, folder) as parent:
                os.rmdir(folder.name, dir_fd=parent)  # only when empty; never a link


def safe_folder(root: Path, name: str) -> Path:
    """``root/name``, a folder made (or found) without following a link on the way, so
    that files written into it land inside ``root``; OSError when a part is a link or a file
    (a planted ``records -> /elsewhere``)."""
    path = plain_name(name)
    if path is None:
        msg = f"`{name}` is not a plain folder name"
        raise OSError(msg)
    with _parent(root, path / "x", create=True):
        pass
    return root.joinpath(*path.parts)
