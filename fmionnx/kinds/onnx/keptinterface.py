"""ONNX models' interfaces, kept between processes (``<cache>/onnx-interfaces``).

Reading an ONNX model's inputs and outputs imports ``onnx`` and parses the model's protobuf:
about a tenth of a second of every compile that the compile cache cannot serve (a system file
just edited), for an answer that depends only on the model's bytes (and its name, which the
ports' origins carry), the limits in force, the reading code and the installed ``onnx``. So
the interface of a model that keeps no tensor in an external file is kept under a key of
exactly those, and a compile of an unchanged model reads it back without importing ``onnx``.
A model with external data (whose files could change without its bytes changing) is read
every time, as a model that fails is.

Entries are kept as the compile cache keeps its own (:mod:`fmionnx.core.keptentries`):
private, signed with this user's key, ignored when they do not check out or do not decode,
bounded in size and age as it is. ``FMIONNX_ONNX_INTERFACES=0`` turns the keeping off.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import importlib.util
import json
import os
from pathlib import Path

from fmionnx.core.cachedir import cache_folder, evict
from fmionnx.core.datacodec import Codec, CodecError
from fmionnx.core.keptentries import read_signed, write_signed
from fmionnx.core.switches import switched_off
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.cache import file_identity, sha256_file

#: The environment variable that turns the keeping off (``0``).
SWITCH = "FMIONNX_ONNX_INTERFACES"
#: The folder's name in the cache.
FOLDER = "onnx-interfaces"
#: The entries' format; a new one makes every older entry a miss.
FORMAT = "fmionnx-onnx-interface-1"
#: The file of an entry, in a folder of its own (the unit the cache's eviction removes).
ENTRY = "interface.json"
#: An entry is larger than this only if someone else wrote it.
MAX_ENTRY_BYTES = 16 << 20

#: How interfaces are written and read back (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec("kept ONNX interface")


def enabled() -> bool:
    """Whether interfaces are kept (``FMIONNX_ONNX_INTERFACES`` unset or not a "no")."""
    return not switched_off(SWITCH)


def kept_interface(path: Path) -> ComponentInterface:
    """The interface of the ONNX model at ``path``: a kept one when an entry checks out, else
    read with ``onnx`` (and kept when the model has no external data). Raises ModelError as
    reading the model does."""
    from fmionnx.kinds.onnx import interface

    entry = _entry(path) if enabled() else None
    if entry is not None:
        found = _read(*entry)
        if found is not None:
            return dataclasses.replace(found, path=path)
    read, external = interface.read_signature(path)
    if entry is not None and not external:
        _write(*entry, read)
    return read


def _entry(path: Path) -> tuple[Path, str] | None:
    """(file, key) of the model's entry; None when it or ``onnx`` cannot be stamped (the
    model is then read, and its errors reported, as without this module)."""
    from fmionnx.core.errors import ModelError
    from fmionnx.kinds.onnx.interface import read_model_bytes

    code = _code_stamps()
    if code is None:
        return None
    try:
        data = read_model_bytes(path)
    except ModelError:
        return None
    environment = [f"{k}={v}" for k, v in sorted(os.environ.items()) if k.startswith("FMIONNX_")]
    parts = [FORMAT, path.name, hashlib.sha256(data).hexdigest(), *code, *environment]
    key = hashlib.sha256("\0".join(parts).encode()).hexdigest()
    return cache_folder(FOLDER) / key[:40] / ENTRY, key


@functools.cache
def _code_stamps() -> tuple[str, ...] | None:
    """``onnx``'s installed package (found without importing it) and fmionnx's modules that
    read a model and define what an entry holds."""
    from fmionnx.core import datacodec, types, units
    from fmionnx.kinds.onnx import external, interface, sizes

    try:
        spec = importlib.util.find_spec("onnx")
        if spec is None or spec.origin is None:
            return None
        modules = (interface, external, sizes, types, units, datacodec)
        readers = [Path(str(m.__file__)) for m in modules]
        readers.append(Path(__file__))
        return (str(file_identity(Path(spec.origin))), *(sha256_file(f) for f in readers))
    except (ImportError, ValueError, OSError):
        return None


def _read(path: Path, key: str) -> ComponentInterface | None:
    """The interface in ``path`` when it is this user's, signed for ``key`` and decodes."""
    body = read_signed(path.parent.parent, path, key, MAX_ENTRY_BYTES)
    if body is None:
        return None
    try:
        found = _CODEC.decode(ComponentInterface, json.loads(body), "interface")
    except (ValueError, CodecError, RecursionError):
        return None
    return found if isinstance(found, ComponentInterface) else None


def _write(path: Path, key: str, interface: ComponentInterface) -> None:
    """Keep ``interface`` under ``key``, the cache bounded as the compile cache is."""
    from fmionnx.core.resources import CACHE_DAYS, COMPILE_CACHE_BYTES

    root = path.parent.parent
    with contextlib.suppress(TypeError, ValueError):
        body = json.dumps(_CODEC.encode(interface), separators=(",", ":")).encode()
        if write_signed(root, path, key, body):
            with contextlib.suppress(OSError):
                evict(root, keep=path.parent, max_bytes=COMPILE_CACHE_BYTES.value(),
                      max_days=CACHE_DAYS.value())  # fmt: skip
