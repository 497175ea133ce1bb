"""Signed entries in a private cache folder: what a model or library answered, kept for the
next process (:mod:`fmionnx.kinds.mujoco.keptfacts`, :mod:`fmionnx.compile.ros2.typecache`).

An entry is a file ``<signature>\\n<body>`` under a cache root whose key file signs it
(:mod:`.private`). The signature covers the entry's key and its body, so an entry copied under
another key's name does not check out either. Reading refuses anything that is not this user's
alone (the root, the entry's folder, the file), is a link, is larger than its bound, or is not
signed with this user's key; the caller then computes the answer again and writes the entry
anew. Writing is never an error: a cache that cannot be written only costs the next process
the work.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from fmionnx.core.private import (
    NotPrivateError,
    check_private_folder,
    read_private,
    signature,
    signed_by,
    user_key,
    write_private,
)


def read_signed(root: Path, file: Path, key: str, limit: int) -> bytes | None:
    """The body of the entry ``file`` (in ``root`` or a folder of it) when it checks out for
    ``key``; None otherwise."""
    try:
        check_private_folder(root)
        if file.parent != root:
            check_private_folder(file.parent)
        claimed, _, body = read_private(file, limit).partition(b"\n")
        secret = user_key(root, make=False)
    except (OSError, NotPrivateError):
        return None
    if not signed_by(secret, _signed(key, body), claimed.decode("ascii", "replace")):
        return None
    return body


def write_signed(root: Path, file: Path, key: str, body: bytes) -> bool:
    """Write the entry ``file`` with ``body`` for ``key``; False when it could not be."""
    with contextlib.suppress(OSError, NotPrivateError):
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
        check_private_folder(root)
        if file.parent != root:
            with contextlib.suppress(FileExistsError):
                file.parent.mkdir(mode=0o700)
            check_private_folder(file.parent)
        claim = signature(user_key(root, make=True), _signed(key, body))
        write_private(file, claim.encode() + b"\n" + body)  # whole, or not at all
        return True
    return False


def _signed(key: str, body: bytes) -> bytes:
    return key.encode() + b"\0" + body
