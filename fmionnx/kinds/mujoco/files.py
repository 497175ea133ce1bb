"""Every file a MuJoCo scene names stays inside the scene's folder.

MuJoCo follows ``<include file=...>`` and reads meshes, textures, height fields and skins from
wherever a ``file`` attribute (joined to ``meshdir``/``texturedir``/``assetdir``) points: a
scene from a supplier could read any file the user can. Before MuJoCo sees the scene, its XML
(and every included file, recursively) is read with the safe parser and each named path is
resolved, links included; one that leaves the scene's folder is refused (E017).
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import MODEL_FILE_BYTES
from fmionnx.core.xmlsafe import parse_safely

#: ``<compiler>`` attributes that are folders the ``file`` attributes are joined to.
_DIR_ATTRIBUTES = ("assetdir", "meshdir", "texturedir")
#: How many files one scene may include (a cycle of includes is also stopped by this).
MAX_INCLUDES = 256


def _inside(path: Path, folder: Path) -> bool:
    return path.resolve().is_relative_to(folder)


def _refuse(scene: Path, where: Path, what: str, value: str) -> ModelError:
    shown = where.name if where == scene else f"{scene.name} (in {where.name})"
    return ModelError(
        "E017",
        f"`{shown}`: {what} `{value}` lies outside the scene's folder",
        hint="keep the scene and every file it names (includes, meshes, textures) in one "
        "folder, named by relative paths inside it",
    )


def check_scene_files(scene: Path) -> None:
    """Raise ModelError E017 when ``scene`` or a file it includes names a path outside its
    folder (the scene itself may be a link: its folder is where it was named). XML that is not
    well-formed and unreadable files are left to MuJoCo, which refuses them with its own
    message before reading anything they name."""
    folder = scene.parent.resolve()
    pending = [scene]
    seen: set[Path] = set()
    while pending:
        current = pending.pop()
        if current.resolve() in seen:
            continue
        seen.add(current.resolve())
        if current != scene and not _inside(current, folder):  # an include that is a link
            raise _refuse(scene, current, "included file", current.name)
        if len(seen) > MAX_INCLUDES:
            msg = f"`{scene.name}` includes more than {MAX_INCLUDES} files"
            raise ModelError("E017", msg)
        try:  # a FIFO or a device as an include would never end (E011)
            data = read_regular(current, MODEL_FILE_BYTES, f"the scene file `{current.name}`")
        except OSError:
            return  # MuJoCo reports the missing or unreadable file with its own message
        try:
            root = parse_safely(data, current.name)
        except ModelError as exc:
            if exc.code == "E012":
                return  # not well-formed: MuJoCo refuses it (naming the line) before any include
            raise
        for compiler in root.iter("compiler"):
            for attribute in _DIR_ATTRIBUTES:
                value = compiler.get(attribute)
                if value is not None and not _inside(folder / value, folder):
                    raise _refuse(scene, current, f"<compiler {attribute}>", value)
        for element in root.iter():
            value = element.get("file")
            if value is None or not isinstance(element.tag, str):
                continue
            if Path(value).is_absolute() or not _inside(folder / value, folder):
                raise _refuse(scene, current, f"<{element.tag} file>", value)
            if element.tag == "include":
                pending.append(folder / value)
