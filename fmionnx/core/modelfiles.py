"""The files a model is shipped with, and the one way they are copied.

``compile --models``, ``export`` (SSP) and ``sweep`` (to its workers) ship every model a
system needs. What belongs to a model is its kind's to say (a MuJoCo scene: the files it
references, not its whole folder; see :func:`fmionnx.kinds.registry.model_files`); how the
files travel is said here, once:

- each is a regular file inside the model's folder -- a link that leaves the folder, a
  device, a FIFO or a socket is refused (a link to ``/dev/zero`` beside a scene filled a disk);
- all of a model's files together are bounded (:data:`MAX_SHIPPED_BYTES`,
  :data:`MAX_SHIPPED_FILES`), checked before anything is copied, and a file that grows while it
  is copied is refused rather than followed.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from fmionnx.core.errors import FmionnxError

#: The ``path`` of an entry without a model file. A kind whose entry can be its own model (its
#: definition is written in the system file) gives ``path`` this default in its model; for every
#: other kind ``path`` stays required and non-empty. (Here, not with the system file's models:
#: a compiled system read back needs it, and none of pydantic.)
NO_MODEL_FILE = ""

#: Bytes all the files of one model may take together when shipped.
MAX_SHIPPED_BYTES = 2 * 1024**3
#: Files one model may ship.
MAX_SHIPPED_FILES = 10_000
_CHUNK = 1 << 20


class ShippingError(FmionnxError):
    """A model's files cannot be shipped: one leaves its folder, is no regular file, or they
    are too large together. The message names the model and the file."""


@dataclass(frozen=True, slots=True, order=True)
class ModelFile:
    """One file a model is shipped with: its name relative to the folder the model file lies
    in (POSIX, as it must be found again beside the shipped model file) and where it is."""

    name: str
    source: Path


def _name(folder: Path, path: Path) -> str | None:
    """``path`` (unresolved) as a plain name inside ``folder``, or None."""
    try:
        name = PurePosixPath(os.path.normpath(path.absolute().relative_to(folder.absolute())))
    except ValueError:
        return None
    text = name.as_posix()
    return None if text in ("", ".") or ".." in name.parts else text


def regular_file(folder: Path, path: Path, model: Path) -> ModelFile:
    """``path`` as a file of the model at ``model`` whose folder is ``folder``: inside it
    once links are followed, and a regular file; ShippingError otherwise."""
    name = _name(folder, path)
    try:
        resolved = path.resolve(strict=True)
        inside = resolved.is_relative_to(folder.resolve())
        info = resolved.stat()
    except (OSError, RuntimeError):
        inside, info = False, None
    if name is None or not inside:
        msg = f"`{model}`: `{path}` lies outside the model's folder (or is a link out of it)"
        raise ShippingError(msg)
    if info is None or not stat.S_ISREG(info.st_mode):
        msg = f"`{model}`: `{path}` is not a regular file"
        raise ShippingError(msg)
    return ModelFile(name, resolved)


def model_file_alone(path: Path) -> tuple[ModelFile, ...]:
    """A model that is one file: that file (a link to it is followed: the user named it)."""
    try:
        resolved = path.resolve(strict=True)
        regular = stat.S_ISREG(resolved.stat().st_mode)
    except (OSError, RuntimeError):
        regular = False
    if not regular:
        msg = f"`{path}` is not a regular file"
        raise ShippingError(msg)
    return (ModelFile(path.name, resolved),)


def model_folder_tree(path: Path) -> tuple[ModelFile, ...]:
    """A model that is a folder (an unpacked FMU): every file in it, named under the folder's
    own name. A link inside that stays inside is shipped as the file it names; one that
    leaves, and anything but regular files and folders, is refused."""
    root = path.resolve()
    found: list[ModelFile] = []
    for current, folders, files in os.walk(path, followlinks=False):
        here = Path(current)
        for name in list(folders):
            if (here / name).is_symlink():
                folders.remove(name)  # not walked into (a link may loop); refused if it leaves
                if not (here / name).resolve().is_relative_to(root):
                    msg = f"`{path}`: `{here / name}` is a link out of the model's folder"
                    raise ShippingError(msg)
        for name in files:
            shipped = regular_file(path, here / name, path)
            found.append(ModelFile(f"{path.name}/{shipped.name}", shipped.source))
            if len(found) > MAX_SHIPPED_FILES:
                msg = f"`{path}` holds more than {MAX_SHIPPED_FILES} files"
                raise ShippingError(msg)
    return tuple(sorted(found))


def copy_model_files(model: Path, files: Iterable[ModelFile], destination: Path) -> int:
    """Copy ``files`` of the model at ``model`` into ``destination`` under their names;
    returns the bytes copied. Sizes are checked against the bounds before anything is
    copied; ShippingError names what is refused."""
    chosen = sorted(set(files))
    if len(chosen) > MAX_SHIPPED_FILES:
        msg = f"`{model}` ships more than {MAX_SHIPPED_FILES} files"
        raise ShippingError(msg)
    sizes = []
    for file in chosen:
        try:
            info = file.source.lstat()
        except OSError as exc:
            msg = f"`{model}`: cannot read `{file.source}`: {exc.strerror}"
            raise ShippingError(msg) from None
        if not stat.S_ISREG(info.st_mode):
            msg = f"`{model}`: `{file.source}` is not a regular file"
            raise ShippingError(msg)
        sizes.append(info.st_size)
    total = sum(sizes)
    if total > MAX_SHIPPED_BYTES:
        msg = (
            f"`{model}` and the files it references take {total} bytes; a model ships at "
            f"most {MAX_SHIPPED_BYTES} bytes"
        )
        raise ShippingError(msg)
    for file, size in zip(chosen, sizes, strict=True):
        target = destination.joinpath(*PurePosixPath(file.name).parts)
        target.parent.mkdir(parents=True, exist_ok=True)
        _copy_exactly(file.source, target, size, model)
    return total


def _copy_exactly(source: Path, target: Path, size: int, model: Path) -> None:
    """Copy ``size`` bytes of the regular file ``source``; a file that changed size meanwhile
    is refused (never read without end)."""
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(source, flags)
    except OSError as exc:
        msg = f"`{model}`: cannot read `{source}`: {exc.strerror}"
        raise ShippingError(msg) from None
    with os.fdopen(fd, "rb") as stream, target.open("xb") as out:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            msg = f"`{model}`: `{source}` is not a regular file"
            raise ShippingError(msg)
        left = size
        while left > 0:
            chunk = stream.read(min(_CHUNK, left))
            if not chunk:
                break
            out.write(chunk)
            left -= len(chunk)
        if left != 0 or stream.read(1):
            with contextlib.suppress(OSError):
                out.close()
                target.unlink()
            msg = f"`{model}`: `{source}` changed while it was copied"
            raise ShippingError(msg)
    with contextlib.suppress(OSError):
        target.chmod(stat.S_IMODE(source.stat().st_mode) | stat.S_IRUSR | stat.S_IWUSR)
