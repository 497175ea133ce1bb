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
from collections.abc import Callable, Hashable, Iterable
from pathlib import Path
from types import ModuleType
from typing import Generic, TypeVar

from fmionnx.core.types import ComponentInterface

#: How many interfaces to keep; far more than the distinct models of any real system.
MAX_ENTRIES = 256


K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class BoundedCache(Generic[K, V]):
    """At most ``limit`` values, the least recently used one dropped first."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._values: OrderedDict[K, V] = OrderedDict()

    def get_or_load(self, key: K, load: Callable[[], V]) -> V:
        """The value for ``key``, calling ``load`` only on a miss."""
        value = self._values.get(key)
        if value is None:
            value = load()
            self._values[key] = value
            if len(self._values) > self.limit:
                self._values.popitem(last=False)
        else:
            self._values.move_to_end(key)
        return value

    def clear(self) -> None:
        """Forget every value."""
        self._values.clear()


_CACHE: BoundedCache[Hashable, ComponentInterface] = BoundedCache(MAX_ENTRIES)


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
    interface = _CACHE.get_or_load(key, load)
    if interface.path != path:
        interface = dataclasses.replace(interface, path=path)
    return interface


def clear_cache() -> None:
    """Forget every cached interface (tests, long-running processes)."""
    _CACHE.clear()


def code_stamps(installed: Iterable[Path], readers: Iterable[Path]) -> tuple[str, ...] | None:
    """What a kept model answer's key holds of the code behind it: the identity of each file
    of the installed library (found without importing it) and the digest of each of
    fmionnx's modules that read the model; None when one of them cannot be read."""
    try:
        return (*(str(file_identity(f)) for f in installed), *(sha256_file(f) for f in readers))
    except OSError:
        return None


def module_files(*modules: ModuleType) -> list[Path]:
    """The source files of ``modules``."""
    return [Path(str(module.__file__)) for module in modules]


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
