"""ROS 2 message definitions kept between processes (``<cache>/ros2-types``).

The compile checks a system's topics against the standard messages' definitions
(:mod:`.messages`): each message's constants and fields, which rosbags keeps in the typestore
of each ROS 2 distribution. Getting a typestore imports a module that defines a Python class
for every message of that distribution and of every one before it: 0.1-0.2 s of every compile
the compile cache cannot serve (a system file just edited), for definitions that change only
with rosbags. So the definitions of a distribution (the store's ``fielddefs``) are written
to the cache folder the first time, as JSON, and read back in a few milliseconds after that.
Encoding and serialization (the ROS 2 backend) still use the typestore itself.

The key is the distribution and rosbags' installed store modules (each file's path, size and
modification time), so an upgraded rosbags makes a new entry. Entries are kept as the
compile cache keeps its own (:mod:`fmionnx.core.private`): in a folder of this user's that
nobody else may write, never read through a link, signed with this user's key. An entry that
does not check out, or does not have the shape of the definitions, is ignored: the
definitions then come from rosbags and the entry is written again. ``FMIONNX_ROS2_TYPES=0``
turns the keeping off.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype

from fmionnx.core.cachedir import cache_folder
from fmionnx.core.keptentries import read_signed, write_signed
from fmionnx.core.switches import switched_off
from fmionnx.kinds.cache import file_identity

#: The environment variable that turns the keeping off (``0``).
SWITCH = "FMIONNX_ROS2_TYPES"
#: The folder's name in the cache.
FOLDER = "ros2-types"
#: The entries' format; a new one makes every older entry a miss.
FORMAT = "fmionnx-ros2-types-1"
#: An entry is larger than this only if someone else wrote it (a distribution's definitions
#: take about 40 KB).
MAX_ENTRY_BYTES = 8 << 20

#: A store's definitions as rosbags gives them: message type -> (constants, fields).
Fielddefs = dict[str, tuple[list[tuple[str, str, Any]], list[tuple[str, Any]]]]


def enabled() -> bool:
    """Whether definitions are kept (``FMIONNX_ROS2_TYPES`` unset or not a "no")."""
    return not switched_off(SWITCH)


def kept_fielddefs(store: str, load: Callable[[], Fielddefs]) -> Fielddefs:
    """The definitions of rosbags' store ``store`` (``ros2_humble``): the kept ones when an
    entry checks out, else ``load()``'s, which are then kept."""
    if not enabled():
        return load()
    entry = _entry(store)
    if entry is not None:
        found = _read(*entry)
        if found is not None:
            return found
    definitions = load()
    if entry is not None:
        _write(*entry, definitions)
    return definitions


def _entry(store: str) -> tuple[Path, str] | None:
    """(file, key) of ``store``'s entry; None when rosbags' stores cannot be found."""
    stamps = _store_stamps()
    if stamps is None:
        return None
    key = hashlib.sha256("\0".join([FORMAT, store, *stamps]).encode()).hexdigest()
    return cache_folder(FOLDER) / f"{key[:40]}.json", key


@functools.cache
def _store_stamps() -> tuple[str, ...] | None:
    """rosbags' store modules (found without importing them: that import is what an entry
    saves), by path, size and modification time."""
    with contextlib.suppress(ImportError, ValueError, OSError):
        spec = importlib.util.find_spec("rosbags.typesys.stores")
        if spec is not None and spec.submodule_search_locations:
            folder = Path(next(iter(spec.submodule_search_locations)))
            return tuple(str(file_identity(f)) for f in sorted(folder.glob("*.py")))
    return None


def _read(path: Path, key: str) -> Fielddefs | None:
    """The definitions in ``path`` when it is this user's, signed for ``key`` and well formed."""
    body = read_signed(path.parent, path, key, MAX_ENTRY_BYTES)
    if body is None:
        return None
    try:
        return _decode(json.loads(body))
    except (ValueError, TypeError, KeyError, IndexError):
        return None


def _write(path: Path, key: str, definitions: Fielddefs) -> None:
    """Keep ``definitions`` under ``key``; a cache that cannot be written is no error."""
    with contextlib.suppress(TypeError, ValueError):
        body = json.dumps(definitions, separators=(",", ":")).encode()
        write_signed(path.parent, path, key, body)


def _decode(data: object) -> Fielddefs | None:
    """rosbags' definitions back from their JSON: the same lists, tuples and node types, or
    None when ``data`` does not have their shape (raises on a malformed part)."""
    if not isinstance(data, dict):
        return None
    decoded: Fielddefs = {}
    for name, (constants, fields) in data.items():
        decoded[str(name)] = (
            [(str(c), str(base), _constant(value)) for c, base, value in constants],
            [(str(field), _description(description)) for field, description in fields],
        )
    return decoded


def _constant(value: object) -> Any:
    if isinstance(value, bool | int | float | str):
        return value
    raise TypeError(f"a constant's value: {value!r}")


def _description(description: list[Any]) -> tuple[Nodetype, Any]:
    """A field's type: ``(BASE, (name, bound))``, ``(NAME, type)`` or ``(ARRAY|SEQUENCE,
    (element's type, length))``."""
    node, argument = description
    kind = Nodetype(node)
    if kind is Nodetype.BASE:
        base, bound = argument
        return kind, (str(base), int(bound))
    if kind is Nodetype.NAME:
        return kind, str(argument)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        element, length = argument
        return kind, (_description(element), int(length))
    raise ValueError(f"a field's node type: {node!r}")
