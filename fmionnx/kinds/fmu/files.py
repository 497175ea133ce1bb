"""Access to the files of an FMU, packed (``.fmu`` zip) or unpacked (a folder).

Only what the interface reader needs is read: the model description's bytes, the binary
platform folders and whether C sources are shipped. Archives go through
:mod:`fmionnx.core.archive`, so hostile member names, links and zip bombs are refused before
anything is read.

The shared library an FMU runs is ``binaries/<platform>/<modelIdentifier>.so``, a path built
from a string of the model description. A ``modelIdentifier`` such as ``../../../elsewhere/x`` or
``/usr/lib/x`` would make fmpy load a library from anywhere, so the identifier is checked when
the interface is read (:func:`check_model_identifier`) and the library's real location, links
followed, again just before it is loaded (:func:`contained_library`).
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from fmionnx.core import codes
from fmionnx.core.archive import CORRUPT_ZIP_ERRORS, check_archive, open_zip
from fmionnx.core.errors import ModelError
from fmionnx.kinds.cache import sha256_file, sha256_tree

MODEL_DESCRIPTION = "modelDescription.xml"

#: What a model identifier may not contain: it names a file inside ``binaries/<platform>/``.
_NOT_IN_IDENTIFIER = ("/", "\\", "\0", ":")
#: Shared-library suffixes fmpy appends on Linux, macOS and Windows.
_LIBRARY_SUFFIXES = (".so", ".dylib", ".dll")

#: A model description larger than this is not a model description.
MAX_MODEL_DESCRIPTION_BYTES = 256 * 1024**2

_NO_DESCRIPTION_HINT = (
    "an FMU is a zip archive with modelDescription.xml at its top level "
    "(FMI 2.0/3.0 standard, section 'FMU distribution')"
)


@dataclass(frozen=True, slots=True)
class FmuFiles:
    """What an FMU's files say besides the model description's content."""

    model_description: bytes
    platforms: tuple[str, ...]
    has_sources: bool
    content_hash: str


def identity_file(path: Path) -> Path:
    """The file whose identity (path, mtime, size) stands for the FMU in caches.

    The archive itself, or an unpacked folder's model description: a folder's own mtime does
    not change when a file inside it is rewritten.
    """
    return path / MODEL_DESCRIPTION if path.is_dir() else path


def read_fmu_files(path: Path) -> FmuFiles:
    """Read an FMU at ``path`` (zip file or unpacked folder).

    Raises ModelError: E010 missing, E011 folder without a model description or special
    file, E012 not a zip / corrupt / no model description, E017 hostile archive.
    """
    if path.is_dir():
        return _read_folder(path)
    with open_zip(path) as archive:
        check_archive(archive)
        return _read_archive(path, archive)


def _read_archive(path: Path, archive: zipfile.ZipFile) -> FmuFiles:
    try:
        info = archive.getinfo(MODEL_DESCRIPTION)
    except KeyError:
        msg = f"`{path.name}` has no {MODEL_DESCRIPTION}: it is not an FMU"
        raise ModelError(codes.BAD_MODEL, msg, hint=_NO_DESCRIPTION_HINT) from None
    if info.file_size > MAX_MODEL_DESCRIPTION_BYTES:
        msg = f"`{path.name}`: {MODEL_DESCRIPTION} is {info.file_size} bytes, too large"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)
    try:
        data = archive.read(info)
    except CORRUPT_ZIP_ERRORS as exc:
        msg = f"`{path.name}` is corrupt: {exc}"
        raise ModelError(codes.BAD_MODEL, msg) from None
    platforms: set[str] = set()
    has_sources = False
    for member in archive.infolist():
        if member.is_dir():
            continue
        parts = PurePosixPath(member.filename).parts
        if len(parts) >= 3 and parts[0] == "binaries":
            platforms.add(parts[1])
        if parts and parts[0] == "sources":
            has_sources = True
    return FmuFiles(data, tuple(sorted(platforms)), has_sources, sha256_file(path))


def _read_folder(path: Path) -> FmuFiles:
    description = path / MODEL_DESCRIPTION
    if not description.is_file():
        msg = f"`{path}` is a folder without {MODEL_DESCRIPTION}, not an unpacked FMU"
        raise ModelError(codes.NOT_A_FILE, msg, hint=_NO_DESCRIPTION_HINT)
    try:
        data = description.read_bytes()
    except OSError as exc:
        msg = f"cannot read `{description}`: {exc.strerror}"
        raise ModelError(codes.FILE_NOT_FOUND, msg) from None
    binaries = path / "binaries"
    platforms = (
        tuple(
            sorted(
                d.name
                for d in binaries.iterdir()
                if d.is_dir() and any(f.is_file() for f in d.iterdir())
            )
        )
        if binaries.is_dir()
        else ()
    )
    sources = path / "sources"
    has_sources = sources.is_dir() and any(f.is_file() for f in sources.rglob("*"))
    return FmuFiles(data, platforms, has_sources, sha256_tree(path))


def check_model_identifier(identifier: str) -> None:
    """Raise ModelError (E017) for a model identifier that is not a plain file name.

    FMI requires a C identifier; fmionnx insists only on what keeps the library inside the
    FMU: no folder separators, no drive, no ``.``/``..``, no control character, not empty.
    """
    if (
        not identifier
        or identifier in (".", "..")
        or any(mark in identifier for mark in _NOT_IN_IDENTIFIER)
        or any(ord(c) < 32 for c in identifier)
    ):
        msg = (
            f"modelIdentifier `{identifier}` is not a plain name: the shared library it names "
            "would lie outside the FMU's binaries folder"
        )
        raise ModelError(
            codes.UNSAFE_ARCHIVE, msg, hint="FMI requires the model identifier to be a C identifier"
        )


def contained_library(root: Path, identifier: str) -> None:
    """Raise ModelError (E017) unless every library ``identifier`` names in ``root`` lies
    inside ``root`` once links are followed (called right before fmpy loads it)."""
    check_model_identifier(identifier)
    inside = root.resolve()
    binaries = root / "binaries"
    if not binaries.is_dir():
        return
    for platform in binaries.iterdir():
        for suffix in _LIBRARY_SUFFIXES:
            library = platform / (identifier + suffix)
            if (library.exists() or library.is_symlink()) and not library.resolve().is_relative_to(
                inside
            ):
                msg = f"`{library.relative_to(root)}` is a link to a file outside the FMU"
                raise ModelError(codes.UNSAFE_ARCHIVE, msg)
