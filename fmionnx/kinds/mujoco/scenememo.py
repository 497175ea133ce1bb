"""What this process read from a scene, kept while the scene's files stay as they were.

A compile asks a scene for its ports, sites and map in turn, and a run loads it again: the
answers are kept in the process (:func:`~.interface.load_model`, :func:`~.keptfacts.scene_facts`).
A scene is more than its file, though: it includes other files and names meshes and
textures. Keyed by the scene file alone, a long-running process (the editor's language
server, a notebook) went on answering from a scene whose included file had changed. So each
answer is kept with the identity of every file the scene is shipped with
(:func:`~.files.scene_files`), taken *before* it was read, and is given back only while all
of them are unchanged: a few ``stat`` calls, no parsing.

A file's identity is that of the name the scene uses (``lstat``: a link retargeted is a
change) and of what it leads to (``stat``: inode, modification time, size). A file modified
shortly before the answer was read (:data:`RACY_NS`) may change again within its
modification time's resolution without any of that changing, so such an answer is not given
back: the scene is read again, and its later answer stamped afresh (git's "racily clean").
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Generic, TypeVar

T = TypeVar("T")

#: A file modified this close before its answer was read may have changed unseen.
RACY_NS = 2_000_000_000

#: Per file: its name's and its target's (inode, modification time in ns, size).
Stamp = tuple[str, int, int, int, int, int, int]
Stamps = tuple[Stamp, ...]


def _stamp(path: Path) -> Stamp:
    named, target = path.lstat(), path.stat()
    return (
        str(path),
        named.st_ino, named.st_mtime_ns, named.st_size,
        target.st_ino, target.st_mtime_ns, target.st_size,
    )  # fmt: skip


def scene_stamps(path: Path) -> Stamps:
    """The identities of the scene's files now: the scene itself first, then every file it
    names, by the names it uses (only the scene when those cannot be listed: its reading then
    fails, or it is read again when the scene file changes). Raises OSError when the scene
    cannot be stat'ed."""
    from fmionnx.core.errors import FmionnxError
    from fmionnx.kinds.mujoco.files import scene_files

    itself = _stamp(path)
    try:
        named = [path.parent / f.name for f in scene_files(path)]
        return (itself, *(_stamp(f) for f in named if f != path))
    except (OSError, ValueError, FmionnxError):
        return (itself,)


class SceneMemo(Generic[T]):
    """Answers by scene, each valid while the scene's files are those it was read from."""

    def __init__(self) -> None:
        self._kept: dict[str, tuple[Stamps, int, T]] = {}

    def get(self, path: Path) -> T | None:
        """The kept answer for the scene at ``path``, or None (none, a file changed, or one
        changed too shortly before the answer was read to tell)."""
        found = self._kept.get(str(path))
        if found is None:
            return None
        stamps, stamped_at, answer = found
        try:
            if any(max(s[2], s[5]) >= stamped_at - RACY_NS for s in stamps):
                return None
            if all(_stamp(Path(s[0])) == s for s in stamps):
                return answer
        except OSError:
            pass
        return None

    def put(self, stamps: Stamps, answer: T, stamped_at: int) -> None:
        """Keep ``answer``, read from the scene whose files had ``stamps`` at
        ``stamped_at`` (:func:`time.time_ns`, taken before :func:`scene_stamps`)."""
        self._kept[stamps[0][0]] = (stamps, stamped_at, answer)

    def clear(self) -> None:
        """Forget every answer (tests: as a new process)."""
        self._kept.clear()


def stamped_now(path: Path) -> tuple[Stamps, int]:
    """(:func:`scene_stamps`, the time they were taken): what :meth:`SceneMemo.put` needs."""
    now = time.time_ns()
    return scene_stamps(path), now
