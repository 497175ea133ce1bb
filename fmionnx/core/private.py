"""Files of the cache that decide what runs: private to this user, and signed.

An entry of the cache that lets fmionnx skip a check (a compiled system, a model's verdict)
must not be one that someone else wrote or changed. Such entries are read only from folders
and files owned by this user that nobody else may write, never through a link, and carry an
HMAC-SHA256 with a key of 32 random bytes kept beside them (``.key``, readable by this user
alone). A key that is readable by others, a link or not a key is replaced when a writer needs
one: every entry signed with the old key is then refused, and written again.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import os
import secrets
import stat
from pathlib import Path

#: The key's file name in a folder of signed entries.
KEY_FILE = ".key"


class NotPrivateError(Exception):
    """A file or folder that must not be used (not private, a link, damaged, not a key)."""


def owned_privately(info: os.stat_result, *, folder: bool, secret: bool = False) -> bool:
    """Owned by this user, writable by nobody else (a ``secret`` not even readable), and a
    plain folder or file (no link)."""
    kind = stat.S_ISDIR(info.st_mode) if folder else stat.S_ISREG(info.st_mode)
    others = 0o077 if secret else 0o022
    return kind and info.st_uid == os.getuid() and not info.st_mode & others


def check_private_folder(folder: Path) -> None:
    """Raise :class:`NotPrivateError` unless ``folder`` is a private folder of this user."""
    if not owned_privately(os.lstat(folder), folder=True):
        msg = f"{folder} is not a private folder of this user"
        raise NotPrivateError(msg)


def read_private(file: Path, limit: int, *, secret: bool = False) -> bytes:
    """The bytes of ``file``, a private file of this user, opened without following a link."""
    handle = os.open(file, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    try:
        if not owned_privately(os.fstat(handle), folder=False, secret=secret):
            msg = f"{file} is not a private file of this user"
            raise NotPrivateError(msg)
        with os.fdopen(handle, "rb", closefd=False) as stream:
            data = stream.read(limit + 1)
    finally:
        os.close(handle)
    if len(data) > limit:
        msg = f"{file} is larger than {limit} bytes"
        raise NotPrivateError(msg)
    return data


def user_key(root: Path, *, make: bool) -> bytes:
    """This user's key for signing the entries in ``root``, readable by nobody else.

    A writer (``make``) whose key is missing or unusable (readable by others, a link, not a
    key) makes a new one: the entries signed with the old key are then refused and written
    again, one by one.
    """
    file = root / KEY_FILE
    try:
        return _load_key(file)
    except (OSError, NotPrivateError):
        if not make:
            raise
    with contextlib.suppress(FileNotFoundError):
        file.unlink()
    with contextlib.suppress(FileExistsError):  # else another process made one meanwhile
        handle = os.open(file, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        with os.fdopen(handle, "wb") as stream:
            stream.write(secrets.token_bytes(32))
    return _load_key(file)


def _load_key(file: Path) -> bytes:
    key = read_private(file, 64, secret=True)
    if len(key) != 32:
        msg = f"{file} is not a key"
        raise NotPrivateError(msg)
    return key


def write_private(path: Path, data: bytes) -> None:
    """Write ``data`` as ``path`` in a private folder: through a new file of this user alone
    (never through a link), renamed over ``path``, so readers see the old file or the new one
    whole. Raises OSError; the new file is gone either way."""
    partial = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
    handle = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        partial.replace(path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            partial.unlink()


def signature(key: bytes, body: bytes) -> str:
    """The hex HMAC-SHA256 of ``body`` under ``key``."""
    return hmac.new(key, body, hashlib.sha256).hexdigest()


def signed_by(key: bytes, body: bytes, claimed: str) -> bool:
    """Whether ``claimed`` is ``body``'s signature under ``key`` (compared in constant time)."""
    return hmac.compare_digest(claimed, signature(key, body))
