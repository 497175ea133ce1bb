"""Read a file only when it is a regular file of bounded size.

Every file fmionnx reads may have been named by someone else: a scene's include, a compiled
system from another host, a resource of an SSP, an ONNX model's external data. A name can
point at a FIFO (``open`` waits for ever for a writer, and Ctrl-C does not help while it
waits in the kernel), at ``/dev/zero`` or ``/dev/urandom`` (a read never ends), or at a
device whose opening has effects of its own. So a file is looked at before it is opened
(``stat``, links followed: a link to a device is refused like the device), opened without
waiting (``O_NONBLOCK``), looked at again through the open descriptor (the name may have been
swapped meanwhile) and read up to its limit and not a byte further.

Refusals are :class:`~fmionnx.core.errors.ModelError`: E011 for a file that is not a regular
file, E008 for one larger than its limit. A missing or unreadable file raises ``OSError`` as
``open`` does, for the caller to report in its own words.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.resources import ResourceLimit


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a special file"


def _refused(what: str, mode: int) -> ModelError:
    msg = f"{what} is {_kind(mode)}, not a regular file"
    return ModelError(
        codes.NOT_A_FILE,
        msg,
        hint="fmionnx reads only regular files (a FIFO or a device would never end or never start)",
    )


def _too_large(what: str, size: int, limit: ResourceLimit) -> ModelError:
    return limit.exceeded(f"{what} is {size} bytes, more than {limit.value()}")


def regular_size(path: Path, limit: ResourceLimit, what: str) -> int:
    """The size of ``path`` (links followed) when it is a regular file within ``limit``.

    ``what`` names the file in messages, as the subject of a sentence (``the include
    `parts.xml```). Raises ModelError (E011, E008) or OSError (missing, unreadable).
    """
    info = path.stat()
    if not stat.S_ISREG(info.st_mode):
        raise _refused(what, info.st_mode)
    if info.st_size > limit.value():
        raise _too_large(what, info.st_size, limit)
    return info.st_size


def read_regular(path: Path, limit: ResourceLimit, what: str) -> bytes:
    """The bytes of ``path`` when it is a regular file of at most ``limit`` bytes.

    Checked before it is opened and again through the open descriptor; never more than the
    limit is read, even from a file that grows meanwhile. Raises ModelError (E011, E008) or
    OSError (missing, unreadable).
    """
    regular_size(path, limit, what)
    largest = limit.value()
    handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        info = os.fstat(handle)
        if not stat.S_ISREG(info.st_mode):  # swapped for a special file since the stat
            raise _refused(what, info.st_mode)
        data = _read_up_to(handle, largest + 1)
    finally:
        os.close(handle)
    if len(data) > largest:
        raise _too_large(what, len(data), limit)
    return data


def _read_up_to(handle: int, size: int) -> bytes:
    """At most ``size`` bytes from the open file ``handle``: fewer only at its end."""
    chunks: list[bytes] = []
    left = size
    while left > 0 and (chunk := os.read(handle, min(1 << 20, left))):
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def read_head(
    path: Path | str, size: int, *, follow: bool = True, dir_fd: int | None = None
) -> bytes | None:
    """Up to ``size`` bytes from the start of ``path`` when it is a regular file; None when
    it is anything else (a directory, a FIFO, a device; with ``follow=False`` a link too).

    For a caller that only looks (a cache's key, whether a file is one of ours), where
    anything but a regular file is simply not what it looks for. Opened without waiting and
    looked at through the descriptor, which is always closed. Raises OSError as ``open``
    does (missing, unreadable; ``ELOOP`` for a link with ``follow=False``).
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    handle = os.open(path, flags, dir_fd=dir_fd)
    try:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            return None
        return _read_up_to(handle, size)
    finally:
        os.close(handle)
