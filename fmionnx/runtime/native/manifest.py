"""Names, flags and the build manifest of the kernel library, shared by every build of it.

The library is built by ``setup.py`` when fmionnx is installed and, only on request
(``FMIONNX_NATIVE=build``), at run time into a cache (:mod:`.runbuild`). Both builds write a
manifest beside the library: the sha256 of the library they wrote and of the source they
compiled. A library is loaded only after its bytes are checked against that record, so a
truncated, replaced or stale file — or one built from another ``fmi2_group.c`` than the one
beside this module, as after editing the source of an editable install — is refused with a
reason instead of being run.

This module uses the standard library only: ``setup.py`` loads it by path, before fmionnx
and its dependencies are importable.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import NamedTuple

#: The C source, shipped as package data beside this module.
SOURCE_NAME = "fmi2_group.c"

#: The library file: a plain C shared library, not a Python extension module (no ``PyInit_``);
#: the ``lib`` prefix and the suffix are those of the platform, not ``EXTENSION_SUFFIXES``.
LIBRARY_NAME = "fmi2_group.dll" if sys.platform == "win32" else "libfmi2_group.so"

#: The build manifest beside the library.
MANIFEST_NAME = "libfmi2_group.build.json"

#: Compiler flags of every build (with ``-shared -fPIC`` or the platform's equivalent).
#: ``-ffp-contract=off``: ``factor*x + offset`` must round twice, as numpy does; ``-O2`` last
#: wins over the optimisation level of Python's own CFLAGS, which setuptools puts first.
COMPILE_FLAGS = ("-O2", "-std=c99", "-ffp-contract=off")

#: The manifest format; a manifest of another format is refused like a missing one.
FORMAT = 1


def sha256_of(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_manifest(folder: Path, source: Path, built_by: str, compiler: str) -> Path:
    """Record ``folder/LIBRARY_NAME`` as built from ``source``; written atomically."""
    record = {
        "format": FORMAT,
        "library": LIBRARY_NAME,
        "sha256": sha256_of(folder / LIBRARY_NAME),
        "source_sha256": sha256_of(source),
        "built_by": built_by,
        "compiler": compiler,
    }
    target = folder / MANIFEST_NAME
    fd, partial = tempfile.mkstemp(prefix=".manifest-", suffix=".json", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as stream:
            json.dump(record, stream, indent=2)
            stream.write("\n")
        Path(partial).chmod(0o644)  # mkstemp's 0600 would hide it from other users
        Path(partial).replace(target)
    finally:
        Path(partial).unlink(missing_ok=True)
    return target


class Verified(NamedTuple):
    """A library whose bytes match its manifest, built from the expected source."""

    path: Path
    sha256: str
    built_by: str


#: A file as :func:`os.stat` last saw it: device, inode, size, modification and change times.
Signature = tuple[int, int, int, int, int]

#: Libraries this process verified, by folder and source, with the signatures of the library,
#: its manifest and the source when they were hashed.
_VERIFIED: dict[tuple[Path, Path], tuple[tuple[Signature, ...], Verified]] = {}


def check_built(folder: Path, source: Path) -> Verified | str:
    """``folder``'s library when it is the one its manifest records and was built from
    ``source``; else why it must not be loaded.

    Every run checks its kernel, and a sweep's worker starts a run each millisecond: hashing
    the library and the source each time was a tenth of such a run. So a library this process
    verified is not hashed again while the three files keep the signature they had then (a
    file written or replaced since changes it, and is checked again).
    """
    signatures = _signatures(folder / LIBRARY_NAME, folder / MANIFEST_NAME, source)
    known = _VERIFIED.get((folder, source))
    if signatures is not None and known is not None and known[0] == signatures:
        return known[1]
    verdict = _check_built(folder, source)
    if signatures is not None and isinstance(verdict, Verified):
        _VERIFIED[(folder, source)] = (signatures, verdict)
    return verdict


def _signatures(*paths: Path) -> tuple[Signature, ...] | None:
    """The files' signatures, taken before they are read (None: one cannot be seen)."""
    try:
        found = [path.stat() for path in paths]
    except OSError:
        return None
    return tuple((st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns) for st in found)


def _check_built(folder: Path, source: Path) -> Verified | str:
    library = folder / LIBRARY_NAME
    if not library.is_file():
        return f"{library} does not exist"
    try:
        record = json.loads((folder / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return f"{library} has no readable build manifest {MANIFEST_NAME} ({exc})"
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        return f"{folder / MANIFEST_NAME} is not a build manifest of format {FORMAT}"
    try:
        actual = sha256_of(library)
        source_digest = sha256_of(source)
    except OSError as exc:
        return f"cannot hash the kernel library or its source: {exc}"
    if record.get("library") != LIBRARY_NAME or record.get("sha256") != actual:
        return (
            f"{library} is not the library its build recorded (sha256 {actual[:12]}…, "
            f"manifest says {str(record.get('sha256'))[:12]}…): refusing to load it"
        )
    if record.get("source_sha256") != source_digest:
        return (
            f"{library} was built from another {SOURCE_NAME} than {source} "
            "(the source changed since the build): refusing to load it"
        )
    return Verified(library, actual, str(record.get("built_by")))
