"""Unpack ``.ssp`` archives safely into a cache folder keyed by the archive's content hash.

The same archive is extracted once; its resources (FMUs, ONNX models, scenes, ``.ssv``) then
have stable absolute paths the compiled system can refer to. Extraction goes to a fresh
temporary folder that is renamed into place only when complete, so a refused (hostile) or
interrupted archive never leaves a half-filled cache entry, and nothing is written outside
the cache folder (:func:`fmionnx.core.archive.safe_extract` refuses ``..``, absolute paths, links
and zip bombs with E017).

The cache is bounded (:func:`fmionnx.core.cachedir.evict`): each use marks an entry as
recently used, and each new unpack removes entries unused for ``FMIONNX_CACHE_MAX_DAYS`` days
and then the least recently used beyond ``FMIONNX_CACHE_MAX_BYTES``.
"""

from __future__ import annotations

import hashlib
import shutil
import tempfile
from pathlib import Path, PurePosixPath

from fmionnx.core import codes
from fmionnx.core.archive import open_zip, safe_extract
from fmionnx.core.cachedir import cache_folder, evict, touch, work_prefix
from fmionnx.core.errors import ModelError
from fmionnx.core.pathnames import remember_archive
from fmionnx.core.regularfile import regular_size
from fmionnx.core.resources import CACHE_BYTES, CACHE_DAYS, MODEL_FILE_BYTES

#: Name of the system structure inside an SSP archive (SSP 1.0, section 7).
SSD_NAME = "SystemStructure.ssd"


def cache_root() -> Path:
    """Where archives are unpacked: ``$FMIONNX_CACHE/ssp`` or the XDG cache folder."""
    return cache_folder("ssp")


def file_digest(path: Path) -> str:
    """sha256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        while chunk := stream.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def refuse_repeated_members(path: Path) -> None:
    """Raise a ModelError (E017) when two members of the archive have the same name.

    Which of them a reader gets depends on the unzipper (Python's takes the last, others the
    first), so such an archive means different systems to different tools, and the first
    ``SystemStructure.ssd`` would be dropped without a word: it is refused, as ambiguous.
    """
    with open_zip(path) as archive:
        seen: set[PurePosixPath] = set()
        for info in archive.infolist():
            name = PurePosixPath(info.filename.replace("\\", "/"))
            if name in seen:
                msg = f"the archive holds two members named `{str(name)[:200]}`"
                hint = "an SSP names each file once; which one is meant is ambiguous"
                raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=hint)
            seen.add(name)


def unpack_ssp(path: Path) -> Path:
    """The folder holding the unpacked archive (extracted now or earlier).

    Raises :class:`fmionnx.core.errors.ModelError` (E010/E012/E017) for missing, corrupt or
    hostile archives.
    """
    # Hashed before anything else: only a regular file (a FIFO or a device never ends, E011).
    try:
        regular_size(path, MODEL_FILE_BYTES, f"the archive `{path.name}`")
    except OSError as exc:
        msg = f"cannot read `{path}`: {exc.strerror}"
        raise ModelError(codes.FILE_NOT_FOUND, msg) from None
    refuse_repeated_members(path)
    folder = cache_root() / file_digest(path)[:24]
    if folder.is_dir():
        touch(folder)
        remember_archive(folder, path)
        return folder
    max_bytes, max_days = CACHE_BYTES.value(), CACHE_DAYS.value()  # a bad setting: before work
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=work_prefix("unpack"), dir=folder.parent))
    try:
        safe_extract(path, staging)
        try:
            staging.rename(folder)
        except OSError:
            # Another process unpacked the same archive meanwhile: theirs is as good.
            if not folder.is_dir():
                raise
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
    evict(folder.parent, keep=folder, max_bytes=max_bytes, max_days=max_days)
    remember_archive(folder, path)
    return folder
