"""The files a MuJoCo scene names: each stays inside the scene's folder, and only they ship.

MuJoCo follows ``<include file=...>`` and reads meshes, textures (a cube's six faces too:
``fileright``, ``fileleft``, ...), height fields, skins and attached models from wherever a
``file`` attribute (joined to ``meshdir``/``texturedir``/``assetdir``) points: a scene from a
supplier could read any file the user can. Before MuJoCo sees the scene, its XML (and every
included file, recursively) is read with the safe parser and each named path is resolved,
links included; one that leaves the scene's folder is refused (E017).

The same reading says what a scene needs when it is shipped (``compile --models``, ``export``,
``sweep``): the scene and the files it names (:func:`scene_files`), never the rest of its
folder -- an SSP export packed the SSH keys and secrets found beside a scene.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.modelfiles import ModelFile, ShippingError, model_file_alone, regular_file
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import MODEL_FILE_BYTES
from fmionnx.core.xmlsafe import parse_safely

#: ``<compiler>`` attributes that are folders the ``file`` attributes are joined to.
_DIR_ATTRIBUTES = ("assetdir", "meshdir", "texturedir")
#: Attributes that name a file: ``file``, and a cube or skybox texture's six faces.
_FILE_ATTRIBUTES = (
    "file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback",
)  # fmt: skip
#: Which compiler folders an element's files are looked up in (after ``assetdir``'s default):
#: meshes, skins and height fields in ``meshdir``, textures in ``texturedir``.
_FOLDER_OF = {"mesh": "meshdir", "skin": "meshdir", "hfield": "meshdir", "texture": "texturedir"}
#: How many files one scene may include (a cycle of includes is also stopped by this).
MAX_INCLUDES = 256


def _inside(path: Path, folder: Path) -> bool:
    return path.resolve().is_relative_to(folder)


def _refuse(scene: Path, where: Path, what: str, value: str) -> ModelError:
    shown = where.name if where == scene else f"{scene.name} (in {where.name})"
    return ModelError(
        codes.UNSAFE_ARCHIVE,
        f"`{shown}`: {what} `{value}` lies outside the scene's folder",
        hint="keep the scene and every file it names (includes, meshes, textures) in one "
        "folder, named by relative paths inside it",
    )


@dataclass
class _Reading:
    """What reading a scene and its includes found."""

    #: The XML files read: the scene, then its includes.
    documents: list[Path] = field(default_factory=list)
    #: (element tag, value) of every file-naming attribute but includes.
    named: list[tuple[str, str]] = field(default_factory=list)
    #: The ``<compiler>`` folders (the last one of each name wins, as in MuJoCo).
    folders: dict[str, str] = field(default_factory=dict)
    #: Whether everything was read (False: a file MuJoCo will refuse; nothing more to say).
    whole: bool = True


def _read(scene: Path) -> _Reading:
    """Read ``scene`` and its includes, checking every name (E017); see the module."""
    folder = scene.parent.resolve()
    reading = _Reading()
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
            raise ModelError(codes.UNSAFE_ARCHIVE, msg)
        try:  # a FIFO or a device as an include would never end (E011)
            data = read_regular(current, MODEL_FILE_BYTES, f"the scene file `{current.name}`")
        except OSError:
            reading.whole = False
            return reading  # MuJoCo reports the missing or unreadable file with its own message
        try:
            root = parse_safely(data, current.name)
        except ModelError as exc:
            if exc.code == codes.BAD_MODEL:
                reading.whole = False
                return reading  # not well-formed: MuJoCo refuses it (naming the line) first
            raise
        reading.documents.append(current)
        for compiler in root.iter("compiler"):
            for attribute in _DIR_ATTRIBUTES:
                value = compiler.get(attribute)
                if value is not None:
                    if not _inside(folder / value, folder):
                        raise _refuse(scene, current, f"<compiler {attribute}>", value)
                    reading.folders[attribute] = value
        for element in root.iter():
            if not isinstance(element.tag, str):
                continue
            for attribute in _FILE_ATTRIBUTES:
                value = element.get(attribute)
                if value is None:
                    continue
                if Path(value).is_absolute() or not _inside(folder / value, folder):
                    raise _refuse(scene, current, f"<{element.tag} {attribute}>", value)
                if element.tag == "include":
                    pending.append(folder / value)
                else:
                    reading.named.append((element.tag, value))
    return reading


def check_scene_files(scene: Path) -> None:
    """Raise ModelError E017 when ``scene`` or a file it includes names a path outside its
    folder (the scene itself may be a link: its folder is where it was named). XML that is not
    well-formed and unreadable files are left to MuJoCo, which refuses them with its own
    message before reading anything they name."""
    _read(scene)


def _candidates(folder: Path, reading: _Reading, tag: str, value: str) -> Iterator[Path]:
    """Where MuJoCo may look for ``value`` of a ``tag`` element: the element's compiler
    folder (``meshdir``/``texturedir``, else ``assetdir``), and the scene's folder itself."""
    own = reading.folders.get(_FOLDER_OF.get(tag, ""))
    common = reading.folders.get("assetdir")
    for base in (own, common):
        if base is not None:
            yield folder / base / value
    yield folder / value


def scene_files(scene: Path) -> tuple[ModelFile, ...]:
    """The files the scene at ``scene`` is shipped with: itself, the files it includes and
    every mesh, texture, height field, skin or model it names that exists (as MuJoCo would
    find it), named relative to the scene's folder. ShippingError for a name that reaches
    outside the folder or is no regular file; ModelError (E017) as :func:`check_scene_files`.
    """
    folder = scene.parent
    itself = model_file_alone(scene)  # a link to it is followed: the user named it
    if scene.suffix == ".mjb":  # a compiled model holds its assets
        return itself
    try:
        reading = _read(scene)
    except ModelError as exc:
        raise ShippingError(str(exc)) from None
    found = set(itself)
    found.update(regular_file(folder, document, scene) for document in reading.documents[1:])
    for tag, value in reading.named:
        for candidate in _candidates(folder, reading, tag, value):
            if candidate.exists() or candidate.is_symlink():
                found.add(regular_file(folder, candidate, scene))
    return tuple(sorted(found))
