"""What the tests of kept answers share (:mod:`fmionnx.core.keptentries`): a store's entries
on disk and a forged one."""

from __future__ import annotations

from pathlib import Path

from fmionnx.core.cachedir import cache_folder
from fmionnx.core.keptentries import KeptAnswers


def entries(store: KeptAnswers) -> list[Path]:
    """The entry files ``store`` has written in the cache folder."""
    return sorted(cache_folder(store.folder).glob(f"*/{store.file_name}"))


def forge(entry: Path, honest: bytes, forged: bytes) -> None:
    """Replace ``honest`` by ``forged`` in the body of ``entry``, its signature kept."""
    signed, _, body = entry.read_bytes().partition(b"\n")
    changed = body.replace(honest, forged, 1)
    assert changed != body, f"{honest!r} is not in {entry}"
    entry.write_bytes(signed + b"\n" + changed)
