"""How files inside unpacked archives are named to the user.

An ``.ssp`` is unpacked into a cache folder, but a diagnostic about its SSD should name the
archive the user gave, as ``model.ssp!/SystemStructure.ssd`` (the notation Java tools use for
jar members), not a path deep in the cache. Front ends record each unpacked archive here;
:class:`fmionnx.core.diagnostics.Span` and the reporters ask :func:`archive_member` when naming a
file. The table only grows and holds one entry per archive opened by this process.
"""

from __future__ import annotations

from pathlib import Path

_UNPACKED: dict[Path, Path] = {}


def remember_archive(folder: Path, archive: Path) -> None:
    """Files below ``folder`` are members of ``archive`` (as the user named it)."""
    _UNPACKED[folder.resolve()] = archive


def archive_member(path: Path) -> tuple[Path, str] | None:
    """``(archive, member)`` when ``path`` lies in a remembered unpacked archive, else None."""
    if not _UNPACKED or not path.is_absolute():
        return None
    for folder, archive in _UNPACKED.items():
        if path.is_relative_to(folder):
            return archive, path.relative_to(folder).as_posix()
    return None


def shown(path: Path) -> str:
    """The name to show for ``path``: ``archive!/member`` or the path itself."""
    member = archive_member(path)
    if member is None:
        return str(path)
    return f"{member[0]}!/{member[1]}"
