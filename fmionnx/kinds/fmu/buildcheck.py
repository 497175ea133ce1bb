"""What a source FMU tells its build must stay inside the FMU.

``fmionnx build-fmu`` hands a supplier's FMU to cmake (:mod:`.build`), which writes the
model identifier, the source file names and the preprocessor definitions of
``modelDescription.xml`` (FMI 2 ``<SourceFiles>``) or ``sources/buildDescription.xml`` into a
CMake cache, one ``NAME:TYPE=value`` per line. So before anything is built:

* the model identifier, which names the library cmake writes into ``binaries/<platform>/``,
  must be a plain name (``../../x`` would write the library elsewhere);
* every source file and include folder must lie inside ``sources/``, links followed (a name
  like ``../../../elsewhere/secret.c`` would be compiled into the library);
* no value may hold a control character: a line break inside an XML attribute (``&#10;``)
  would add lines of its own to the CMake cache.

Compiling C code is trusting it (a ``#include`` can name any file); these checks keep the
*file names the description gives* inside the FMU, as everywhere else (E017).

A source *folder* is copied before the build (:func:`copy_source_folder`), and its symbolic
links are judged first, since the built FMU ships every file of the folder: a link to a file
of the folder is copied as that file (a zip holds no links); a broken link is E010; a link out
of the folder is E017, because following it would pack a file the folder does not hold (a
``sources/notes.txt`` linking to the user's ``~/.ssh/id_rsa`` would ship the key), unless the
folder it names says its files are meant to be shared (:data:`SHARED_SOURCES_MARK`): glue code
kept once and linked into several source FMUs, as this project's test FMUs do. A folder being
built cannot plant that mark beside a file of the user's; only whoever owns that folder can.
"""

from __future__ import annotations

import shutil
from pathlib import Path, PurePosixPath

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION, check_model_identifier

BUILD_DESCRIPTION = "sources/buildDescription.xml"
_INTERFACES = ("CoSimulation", "ModelExchange", "ScheduledExecution")


def _plain_text(value: str, what: str, label: str) -> None:
    if any(ord(c) < 32 or c == "\x7f" for c in value):
        msg = f"`{label}`: {what} `{value!r}` holds a control character"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)


def _inside_sources(name: str, sources: Path, what: str, label: str) -> None:
    _plain_text(name, what, label)
    normal = PurePosixPath(name.replace("\\", "/"))
    if (
        not name
        or normal.is_absolute()
        or (len(name) > 1 and name[1] == ":")
        or ".." in normal.parts
        or not (sources / normal).resolve().is_relative_to(sources.resolve())
    ):
        msg = f"`{label}`: {what} `{name}` lies outside the FMU's sources folder"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)


def check_build_inputs(unpacked: Path) -> None:
    """Raise ModelError (E017) when the unpacked source FMU names anything outside itself."""
    sources = unpacked / "sources"
    description = parse_safely((unpacked / MODEL_DESCRIPTION).read_bytes(), MODEL_DESCRIPTION)
    for interface in _INTERFACES:
        for element in description.iterfind(interface):
            identifier = element.get("modelIdentifier") or ""
            _plain_text(identifier, "modelIdentifier", MODEL_DESCRIPTION)
            check_model_identifier(identifier)
            for file in element.iterfind("SourceFiles/File"):
                _inside_sources(file.get("name") or "", sources, "source file", MODEL_DESCRIPTION)
    build = unpacked / BUILD_DESCRIPTION
    if not build.is_file():
        return
    root = parse_safely(build.read_bytes(), BUILD_DESCRIPTION)
    for file in root.iter("SourceFile"):
        _inside_sources(file.get("name") or "", sources, "source file", BUILD_DESCRIPTION)
    for folder in root.iter("IncludeDirectory"):
        _inside_sources(folder.get("name") or "", sources, "include folder", BUILD_DESCRIPTION)
    for element in root.iter():
        if not isinstance(element.tag, str):  # comments, processing instructions
            continue
        for key, value in element.attrib.items():
            _plain_text(str(value), f"{element.tag} {key}", BUILD_DESCRIPTION)


#: A file of this name in a folder outside a source FMU lets the FMU's links name that
#: folder's files (not its subfolders'): the owner's statement that they are meant to be shipped.
SHARED_SOURCES_MARK = "fmionnx-shared-sources.txt"


def copy_source_folder(source: Path, destination: Path) -> None:
    """Copy the source FMU folder ``source`` to ``destination`` (which must not exist), each
    symbolic link replaced by a copy of the file it names after :func:`_link_target` allowed it.

    Raises ModelError: E010 for a broken link, E017 for a link out of the folder, E011 for a
    link to a folder or a special file (a FIFO would block the copy), E012 for an unreadable
    file. Folders are walked without following links, so the walk stays inside ``source``.
    """
    root = source.resolve()
    _copy_folder(root, root, destination)


def _copy_folder(root: Path, folder: Path, destination: Path) -> None:
    destination.mkdir()
    try:
        entries = sorted(folder.iterdir())
    except OSError as exc:
        msg = f"cannot read the folder `{_shown(folder, root)}` of the source: {exc.strerror}"
        raise ModelError(codes.BAD_MODEL, msg) from None
    for entry in entries:
        target = destination / entry.name
        if entry.is_symlink():
            _copy_file(_link_target(entry, root), target, entry, root)
        elif entry.is_dir():
            _copy_folder(root, entry, target)
        elif entry.is_file():
            _copy_file(entry, target, entry, root)
        else:
            msg = f"`{_shown(entry, root)}` in the source folder is a special file, not a file"
            raise ModelError(codes.NOT_A_FILE, msg)


def _copy_file(file: Path, target: Path, entry: Path, root: Path) -> None:
    try:
        shutil.copy2(file, target)
    except OSError as exc:
        msg = f"cannot read `{_shown(entry, root)}` of the source folder: {exc.strerror}"
        raise ModelError(codes.BAD_MODEL, msg) from None


def _shown(entry: Path, root: Path) -> str:
    """``entry``'s name relative to the source folder, as the user knows it."""
    return entry.relative_to(root).as_posix()


def _link_target(link: Path, root: Path) -> Path:
    """The regular file the link ``link`` (inside ``root``) names, if the build may copy it."""
    named = link.readlink().as_posix()
    shown = f"`{_shown(link, root)}` is a link to `{named}`"
    try:
        target = link.resolve(strict=True)
    except (OSError, RuntimeError):  # missing, or a loop of links (RuntimeError before 3.13)
        msg = f"{shown}, which does not exist (a broken link)"
        raise ModelError(
            codes.FILE_NOT_FOUND, msg, hint="remove the link or make it name a file"
        ) from None
    shared = target.is_file() and (target.parent / SHARED_SOURCES_MARK).is_file()
    if not target.is_relative_to(root) and not shared:
        msg = f"{shown}, outside the source folder: the built FMU would ship that file"
        hint = (
            f"copy the file into the folder instead; if `{target.parent}` holds only files "
            f"meant to be shipped with source FMUs, add a file `{SHARED_SOURCES_MARK}` there"
        )
        raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=hint)
    if not target.is_file():
        what = "a folder" if target.is_dir() else "a special file"
        msg = f"{shown}, {what}: a link in a source folder must name a file"
        raise ModelError(codes.NOT_A_FILE, msg, hint="replace the link by what it names")
    return target
