"""Safe handling of zip archives (FMUs and SSPs come from other people).

Extraction refuses path traversal (``../``), absolute paths, drive letters, symbolic links and
archives whose declared or actual size is out of proportion (zip bombs), and writes nothing
outside the destination folder.

Size is bounded per archive, whatever the size of its members: the member count, the total
unpacked size and the ratio of unpacked size to archive size (:mod:`fmionnx.core.resources`,
each changeable by an environment variable). Many small members of zeros are as much a bomb
as one large one. One member with an absurd ratio is refused too, however normal the rest.
"""

from __future__ import annotations

import os
import stat
import zipfile
import zlib
from pathlib import Path, PurePosixPath

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.resources import ARCHIVE_BYTES, ARCHIVE_MEMBERS, ARCHIVE_RATIO, MiB
from fmionnx.core.safewrite import atomic_binary

#: Below this unpacked size a compression ratio says nothing (a small XML file may compress
#: well); above it the ratio limit applies, to each member and to the archive as a whole.
RATIO_FLOOR_BYTES = MiB

#: What reading a damaged or unusual zip raises besides BadZipFile: a truncated stream
#: (EOFError), an unknown compression method or version (NotImplementedError), an encrypted
#: member (RuntimeError), corrupt deflate data (zlib.error), a negative offset in the central
#: directory (ValueError, OSError EINVAL). Every one is a damaged archive to the user.
CORRUPT_ZIP_ERRORS = (
    zipfile.BadZipFile,
    EOFError,
    NotImplementedError,
    RuntimeError,
    zlib.error,
    ValueError,
    OSError,
)

#: The longest name one path component may have on the file systems fmionnx unpacks to.
MAX_NAME_BYTES = 255


def check_member_name(name: str) -> PurePosixPath:
    """The member's relative path, or a ModelError (E017) for a hostile name."""
    normalized = name.replace("\\", "/")
    path = PurePosixPath(normalized)
    if normalized.startswith("/") or (len(normalized) > 1 and normalized[1] == ":"):
        msg = f"archive member `{name}` has an absolute path"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)
    if any(part == ".." for part in path.parts):
        msg = f"archive member `{name}` points outside the archive (`..`)"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)
    if any(len(part.encode("utf-8", "surrogateescape")) > MAX_NAME_BYTES for part in path.parts):
        msg = f"archive member `{name[:80]}...` has a name longer than {MAX_NAME_BYTES} bytes"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)
    return path


def open_zip(path: Path) -> zipfile.ZipFile:
    """Open ``path`` as a zip, turning every failure into a ModelError with a code."""
    if not path.exists():
        msg = f"`{path}` does not exist"
        raise ModelError(codes.FILE_NOT_FOUND, msg)
    if not path.is_file():
        msg = f"`{path}` is a directory or special file, not an archive"
        raise ModelError(codes.NOT_A_FILE, msg)
    try:
        return zipfile.ZipFile(path)
    except FileNotFoundError as exc:
        msg = f"cannot read `{path}`: {exc.strerror}"
        raise ModelError(codes.FILE_NOT_FOUND, msg) from None
    except zipfile.BadZipFile:
        msg = f"`{path}` is not a zip archive (corrupt or not an FMU/SSP)"
        raise ModelError(codes.BAD_MODEL, msg) from None
    except CORRUPT_ZIP_ERRORS as exc:
        msg = f"`{path}` is a damaged zip archive: {exc}"
        raise ModelError(codes.BAD_MODEL, msg) from None


def check_archive(archive: zipfile.ZipFile) -> None:
    """Raise ModelError (E017) when any member is hostile or the archive is a bomb.

    Only the central directory is read: the declared sizes. :func:`safe_extract` enforces
    the size limit again on the bytes actually written, since declared sizes can lie.
    """
    members = archive.infolist()
    most = ARCHIVE_MEMBERS.value()
    if len(members) > most:
        msg = f"archive has {len(members)} members (more than {most})"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=ARCHIVE_MEMBERS.hint())
    ratio = ARCHIVE_RATIO.value()
    total = 0
    compressed = 0
    for info in members:
        check_member_name(info.filename)
        mode = info.external_attr >> 16
        if stat.S_ISLNK(mode):
            msg = f"archive member `{info.filename}` is a symbolic link"
            raise ModelError(codes.UNSAFE_ARCHIVE, msg)
        total += info.file_size
        compressed += info.compress_size
        if info.file_size > RATIO_FLOOR_BYTES and info.file_size > ratio * max(
            info.compress_size, 1
        ):
            msg = (
                f"archive member `{info.filename}` expands "
                f"{info.file_size // max(info.compress_size, 1)}x (zip bomb?)"
            )
            raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=ARCHIVE_RATIO.hint())
    largest = ARCHIVE_BYTES.value()
    if total > largest:
        msg = f"archive expands to {total} bytes (more than {largest})"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=ARCHIVE_BYTES.hint())
    packed = max(1, min(compressed, _archive_size(archive) or compressed))
    if total > RATIO_FLOOR_BYTES and total > ratio * packed:
        msg = (
            f"archive expands {total // packed}x, to {total} bytes from {packed} "
            f"(zip bomb? {len(members)} members)"
        )
        raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=ARCHIVE_RATIO.hint())


def _archive_size(archive: zipfile.ZipFile) -> int:
    """Bytes of the archive file itself (0 when it is not a file on disk)."""
    stream = archive.fp
    try:
        return os.fstat(stream.fileno()).st_size if stream is not None else 0
    except (OSError, AttributeError, ValueError):
        return 0


def safe_extract(path: Path, destination: Path) -> Path:
    """Extract the zip at ``path`` into ``destination`` after :func:`check_archive`.

    Sizes are enforced while writing too, since a zip's declared sizes can lie.
    """
    with open_zip(path) as archive:
        check_archive(archive)
        root = destination.resolve()
        root.mkdir(parents=True, exist_ok=True)
        largest = ARCHIVE_BYTES.value()
        budget = largest
        for info in archive.infolist():
            relative = check_member_name(info.filename)
            target = (root / relative).resolve()
            if not target.is_relative_to(root):
                msg = f"archive member `{info.filename}` points outside the archive"
                raise ModelError(codes.UNSAFE_ARCHIVE, msg)
            if info.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            try:
                with archive.open(info) as source, target.open("wb") as sink:
                    while chunk := source.read(1 << 20):
                        budget -= len(chunk)
                        if budget < 0:
                            msg = f"archive `{path.name}` expands beyond {largest} bytes"
                            raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=ARCHIVE_BYTES.hint())
                        sink.write(chunk)
            except CORRUPT_ZIP_ERRORS as exc:
                msg = f"`{path}` is corrupt: member `{info.filename[:80]}`: {exc}"
                raise ModelError(codes.BAD_MODEL, msg) from None
    return root


def write_deterministic_zip(source_dir: Path, output: Path) -> None:
    """Zip ``source_dir`` with sorted names and fixed timestamps (same input, same bytes)."""
    output.parent.mkdir(parents=True, exist_ok=True)
    # Through a fresh temporary file: a link planted at ``output`` is replaced, not followed.
    with (
        atomic_binary(output) as stream,
        zipfile.ZipFile(stream, "w", compression=zipfile.ZIP_DEFLATED) as archive,
    ):
        for file in sorted(p for p in source_dir.rglob("*") if p.is_file()):
            info = zipfile.ZipInfo(file.relative_to(source_dir).as_posix(), (1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o644 if file.suffix != ".so" else 0o755) << 16
            archive.writestr(info, file.read_bytes())
