"""Answers kept between processes in a private cache folder: what a model or library answered
(:mod:`fmionnx.kinds.mujoco.keptfacts`, :mod:`fmionnx.kinds.onnx.keptinterface`,
:mod:`fmionnx.kinds.fmu.keptinterface`, :mod:`fmionnx.compile.ros2.typecache`).

Each kind of answer is a :class:`KeptAnswers` store: a folder of the cache, a format, a bound
on an entry's size and the environment variable that turns it off. An entry is a file
``<signature>\\n<body>`` in a folder of its own (the unit the cache's eviction removes), named
by its key: a hash of the store's format, what the answer depends on (the caller's parts) and,
unless the store says otherwise, the ``FMIONNX_*`` environment (the limits in force). The
cache root's key file signs it (:mod:`.private`) over the entry's key and its body, so an
entry copied under another key's name does not check out either.

Reading refuses anything that is not this user's alone (the root, the entry's folder, the
file), is a link, is larger than its bound, is not signed with this user's key or does not
decode; the caller then computes the answer again and writes the entry anew. Writing is never
an error: a cache that cannot be written only costs the next process the work. Every store is
bounded in size and age as the compile cache is.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from fmionnx.core.cachedir import cache_folder, evict, touch
from fmionnx.core.datacodec import Codec, CodecError
from fmionnx.core.private import (
    NotPrivateError,
    check_private_folder,
    read_private,
    signature,
    signed_by,
    user_key,
    write_private,
)
from fmionnx.core.switches import switched_off

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Entry:
    """Where an answer is kept (``<root>/<key[:40]>/<file name>``) and the key it is signed for."""

    file: Path
    key: str

    @property
    def root(self) -> Path:
        return self.file.parent.parent


@dataclass(frozen=True, slots=True)
class KeptAnswers:
    """One kind of kept answer: ``folder`` in the cache, ``switch`` (``=0`` turns it off),
    ``format`` (a new one makes every older entry a miss), ``max_bytes`` (an entry larger than
    this was written by someone else) and the file an entry is written to."""

    switch: str
    folder: str
    format: str
    max_bytes: int
    file_name: str = "entry.json"
    #: Whether the ``FMIONNX_*`` environment is part of the key (the limits a model is read
    #: under: :func:`limits_in_force`); False for answers no limit bears on.
    keyed_by_environment: bool = True

    def enabled(self) -> bool:
        """Whether answers are kept (the switch unset or not a "no")."""
        return not switched_off(self.switch)

    def entry(self, parts: Iterable[str]) -> Entry:
        """The entry of the answer that depends on exactly ``parts`` (and the environment)."""
        keyed = [self.format, *parts]
        if self.keyed_by_environment:
            keyed += [f"{k}={v}" for k, v in limits_in_force()]
        key = hashlib.sha256("\0".join(keyed).encode()).hexdigest()
        return Entry(cache_folder(self.folder) / key[:40] / self.file_name, key)

    def read(self, entry: Entry) -> bytes | None:
        """The body kept in ``entry`` when it checks out; None otherwise."""
        body = read_signed(entry.root, entry.file, entry.key, self.max_bytes)
        if body is not None:
            touch(entry.file.parent)  # its place in the least-recently-used order
        return body

    def write(self, entry: Entry, body: bytes) -> None:
        """Keep ``body`` in ``entry``, the store bounded as the compile cache is."""
        from fmionnx.core.resources import CACHE_DAYS, COMPILE_CACHE_BYTES

        if write_signed(entry.root, entry.file, entry.key, body):
            with contextlib.suppress(OSError):
                evict(entry.root, keep=entry.file.parent, max_bytes=COMPILE_CACHE_BYTES.value(),
                      max_days=CACHE_DAYS.value())  # fmt: skip

    def read_value(self, entry: Entry, codec: Codec, kind: type[T]) -> T | None:
        """The ``kind`` kept in ``entry`` (written by :meth:`write_value`) when it checks
        out and decodes as one; None otherwise."""
        body = self.read(entry)
        if body is None:
            return None
        try:
            value = codec.decode(kind, json.loads(body), kind.__name__)
        except (ValueError, CodecError, RecursionError):
            return None
        return value if isinstance(value, kind) else None

    def write_value(self, entry: Entry, codec: Codec, value: object) -> None:
        """Keep ``value`` in ``entry`` as ``codec`` writes it."""
        with contextlib.suppress(TypeError, ValueError):
            self.write(entry, json.dumps(codec.encode(value), separators=(",", ":")).encode())


def limits_in_force() -> list[tuple[str, str]]:
    """The ``FMIONNX_*`` variables an answer may depend on (sorted): every one but the
    cache's own (its folder, bounds and switches), which change where and whether answers
    are kept, never what they are."""
    return sorted(
        (k, v) for k, v in os.environ.items() if k.startswith("FMIONNX_") and "CACHE" not in k
    )


def installed_package(name: str) -> Path | None:
    """The folder of the installed package ``name``, found without importing it (importing it
    is what a kept answer saves); None when it is not installed as a package."""
    with contextlib.suppress(ImportError, ValueError):
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            return Path(next(iter(spec.submodule_search_locations)))
    return None


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
