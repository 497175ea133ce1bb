"""FMU interfaces, kept between processes (``<cache>/fmu-interfaces``).

Reading an FMU's ports parses its model description with fmpy, which brings numpy: about a
quarter of a second of every compile that the compile cache cannot serve (a system file just
edited). For an FMU archive that answer depends only on the archive's bytes (and its name,
which the ports' origins carry), the reading code, the installed fmpy and the limits in force,
so it is kept under a key of exactly those, and a compile of an unchanged FMU reads it back
without importing fmpy. An unpacked FMU folder (whose library check follows the folder's
files and links) is read every time, as an FMU that fails is.

Entries are kept as the compile cache keeps its own (:mod:`fmionnx.core.keptentries`):
private, signed with this user's key, ignored when they do not check out or do not decode,
bounded in size and age as it is. ``FMIONNX_FMU_INTERFACES=0`` turns the keeping off.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import importlib.util
import json
import os
from collections.abc import Callable
from pathlib import Path

from fmionnx.core.cachedir import cache_folder, evict
from fmionnx.core.datacodec import Codec, CodecError
from fmionnx.core.keptentries import read_signed, write_signed
from fmionnx.core.switches import switched_off
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.cache import file_identity, sha256_file

#: The environment variable that turns the keeping off (``0``).
SWITCH = "FMIONNX_FMU_INTERFACES"
#: The folder's name in the cache.
FOLDER = "fmu-interfaces"
#: The entries' format; a new one makes every older entry a miss.
FORMAT = "fmionnx-fmu-interface-1"
#: The file of an entry, in a folder of its own (the unit the cache's eviction removes).
ENTRY = "interface.json"
#: An entry is larger than this only if someone else wrote it.
MAX_ENTRY_BYTES = 64 << 20

#: How interfaces are written and read back (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec("kept FMU interface")


def enabled() -> bool:
    """Whether interfaces are kept (``FMIONNX_FMU_INTERFACES`` unset or not a "no")."""
    return not switched_off(SWITCH)


def kept_interface(path: Path, read: Callable[[], ComponentInterface]) -> ComponentInterface:
    """The interface of the FMU at ``path``: a kept one when an entry checks out, else
    ``read()``'s (kept when ``path`` is an archive). Raises as ``read`` does."""
    entry = _entry(path) if enabled() and path.is_file() else None
    if entry is not None:
        found = _read(*entry)
        if found is not None:
            return dataclasses.replace(found, path=path)
    interface = read()
    if entry is not None:
        _write(*entry, interface)
    return interface


def _entry(path: Path) -> tuple[Path, str] | None:
    """(file, key) of the archive's entry; None when it or fmpy cannot be stamped."""
    code = _code_stamps()
    if code is None:
        return None
    try:
        digest = sha256_file(path)
    except OSError:
        return None
    environment = [f"{k}={v}" for k, v in sorted(os.environ.items()) if k.startswith("FMIONNX_")]
    parts = [FORMAT, path.name, digest, *code, *environment]
    key = hashlib.sha256("\0".join(parts).encode()).hexdigest()
    return cache_folder(FOLDER) / key[:40] / ENTRY, key


@functools.cache
def _code_stamps() -> tuple[str, ...] | None:
    """fmpy's installed package (found without importing it) and fmionnx's modules that read
    an FMU and define what an entry holds (the whole FMU kind, to be safe)."""
    from fmionnx.core import datacodec, types, units, xmlsafe

    try:
        spec = importlib.util.find_spec("fmpy")
        if spec is None or not spec.submodule_search_locations:
            return None
        package = Path(next(iter(spec.submodule_search_locations)))
        installed = [str(file_identity(package / "__init__.py"))]
        installed.append(str(file_identity(package / "model_description.py")))
        kind = sorted(Path(__file__).parent.glob("*.py"))
        modules = [Path(str(m.__file__)) for m in (types, units, datacodec, xmlsafe)]
        return (*installed, *(sha256_file(f) for f in [*kind, *modules]))
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
