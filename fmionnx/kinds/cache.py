"""An in-process cache of parsed interfaces, keyed by file identity.

A system may use one FMU two hundred times, and ``validate`` must stay fast: each model file
is parsed once per process as long as its resolved path, modification time and size are the
same. Interfaces are immutable, so handing out the same object is safe.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path

from fmionnx.core.types import ComponentInterface

#: How many interfaces to keep; far more than the distinct models of any real system.
MAX_ENTRIES = 256

_CACHE: OrderedDict[Hashable, ComponentInterface] = OrderedDict()


def file_identity(path: Path) -> tuple[str, int, int]:
    """(resolved path, mtime in ns, size) of an existing file or folder."""
    info = path.stat()
    return (str(path.resolve()), info.st_mtime_ns, info.st_size)


def cached_interface(
    key: Hashable, path: Path, load: Callable[[], ComponentInterface]
) -> ComponentInterface:
    """The interface for ``key``, calling ``load`` only on a miss.

    The returned interface carries ``path`` as given by this caller (two system files may
    name the same model by different relative paths).
    """
    interface = _CACHE.get(key)
    if interface is None:
        interface = load()
        _CACHE[key] = interface
        if len(_CACHE) > MAX_ENTRIES:
            _CACHE.popitem(last=False)
    else:
        _CACHE.move_to_end(key)
    if interface.path != path:
        interface = dataclasses.replace(interface, path=path)
    return interface


def clear_cache() -> None:
    """Forget every cached interface (tests, long-running processes)."""
    _CACHE.clear()


def sha256_file(path: Path) -> str:
    """Hex sha256 of a file's bytes, read in chunks."""
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        while chunk := stream.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def sha256_tree(folder: Path) -> str:
    """Hex sha256 over a folder's files (relative names and contents, in sorted order)."""
    digest = hashlib.sha256()
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in sorted(files):
            file = Path(root) / name
            if not file.is_file():
                continue
            digest.update(file.relative_to(folder).as_posix().encode())
            digest.update(b"\0")
            digest.update(bytes.fromhex(sha256_file(file)))
    return digest.hexdigest()
