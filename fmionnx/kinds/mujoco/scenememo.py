"""What this process read from a scene, kept while the scene's files stay as they were.

A compile asks a scene for its ports, sites and map in turn, and a run loads it again: the
answers are kept in the process (:func:`~.interface.load_model`, :func:`~.keptfacts.scene_facts`).
A scene is more than its file, though: it includes other files and names meshes and
textures. Keyed by the scene file alone, a long-running process (the editor's language
server, a notebook) went on answering from a scene whose included file had changed. So each
answer is kept with the identity (path, modification time, size) of every file the scene is
shipped with (:func:`~.files.scene_files`), taken *before* it was read, and is given back only
while all of them are unchanged: one ``stat`` per file, no parsing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Generic, TypeVar

from fmionnx.kinds.cache import file_identity

T = TypeVar("T")

#: (path, modification time in ns, size) of each file a scene was read from.
Stamps = tuple[tuple[str, int, int], ...]


def scene_stamps(path: Path) -> Stamps:
    """The identities of the scene's files now: the scene itself first, then every file it
    names (only the scene when those cannot be listed: its reading then fails, or it is read
    again when the scene file changes). Raises OSError when the scene cannot be stat'ed."""
    from fmionnx.core.errors import FmionnxError
    from fmionnx.kinds.mujoco.files import scene_files

    itself = file_identity(path)
    try:
        named = [f.source for f in scene_files(path)]
        return (itself, *(file_identity(f) for f in named if f.resolve() != Path(itself[0])))
    except (OSError, ValueError, FmionnxError):
        return (itself,)


class SceneMemo(Generic[T]):
    """Answers by scene, each valid while the scene's files are those it was read from."""

    def __init__(self) -> None:
        self._kept: dict[str, tuple[Stamps, T]] = {}

    def get(self, path: Path) -> T | None:
        """The kept answer for the scene at ``path``, or None (none, or a file changed)."""
        found = self._kept.get(str(path.resolve()))
        if found is None:
            return None
        stamps, answer = found
        try:
            if all(file_identity(Path(name)) == (name, ns, size) for name, ns, size in stamps):
                return answer
        except OSError:
            pass
        return None

    def put(self, stamps: Stamps, answer: T) -> None:
        """Keep ``answer``, read from the scene whose files had ``stamps`` before reading."""
        self._kept[stamps[0][0]] = (stamps, answer)

    def clear(self) -> None:
        """Forget every answer (tests: as a new process)."""
        self._kept.clear()
