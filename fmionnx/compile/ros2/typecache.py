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
modification time), so an upgraded rosbags makes a new entry. Entries are kept as every kept
answer is (:mod:`fmionnx.core.keptentries`): in a folder of this user's that nobody else may
write, never read through a link, signed with this user's key, bounded in size and age as the
compile cache is. An entry that does not check out, or does not have the shape of the
definitions, is ignored: the definitions then come from rosbags and the entry is written
again. ``FMIONNX_ROS2_TYPES=0`` turns the keeping off.
"""

from __future__ import annotations

import contextlib
import functools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype

from fmionnx.core.keptentries import Entry, KeptAnswers, installed_package
from fmionnx.kinds.cache import code_stamps

#: The store: ``FMIONNX_ROS2_TYPES=0`` turns it off. No limit bears on the definitions: the
#: environment is no part of the key. (A distribution's definitions take about 40 KB.)
STORE = KeptAnswers(
    switch="FMIONNX_ROS2_TYPES",
    folder="ros2-types",
    format="fmionnx-ros2-types-2",
    max_bytes=8 << 20,
    file_name="types.json",
    keyed_by_environment=False,
)

#: A store's definitions as rosbags gives them: message type -> (constants, fields).
Fielddefs = dict[str, tuple[list[tuple[str, str, Any]], list[tuple[str, Any]]]]


def kept_fielddefs(store: str, load: Callable[[], Fielddefs]) -> Fielddefs:
    """The definitions of rosbags' store ``store`` (``ros2_humble``): the kept ones when an
    entry checks out, else ``load()``'s, which are then kept."""
    if not STORE.enabled():
        return load()
    entry = _entry(store)
    if entry is not None:
        found = _read(entry)
        if found is not None:
            return found
    definitions = load()
    if entry is not None:
        with contextlib.suppress(TypeError, ValueError):
            STORE.write(entry, json.dumps(definitions, separators=(",", ":")).encode())
        _drop_flat_entries(entry.root)
    return definitions


def _drop_flat_entries(root: Path) -> None:
    """Remove the entries of format 1, which lay flat in the folder (``<key>.json``), where
    the store's eviction (which removes entry folders) never reaches them."""
    with contextlib.suppress(OSError):
        for old in root.glob("*.json"):
            if old.is_file() and not old.is_symlink():
                old.unlink()


def _entry(store: str) -> Entry | None:
    """``store``'s entry; None when rosbags' stores cannot be found."""
    stamps = _store_stamps()
    return None if stamps is None else STORE.entry([store, *stamps])


@functools.cache
def _store_stamps() -> tuple[str, ...] | None:
    """rosbags' store modules (found without importing them: that import is what an entry
    saves), by path, size and modification time."""
    folder = installed_package("rosbags.typesys.stores")
    return None if folder is None else code_stamps(sorted(folder.glob("*.py")), ())


def _read(entry: Entry) -> Fielddefs | None:
    """The definitions in ``entry`` when it checks out and is well formed."""
    body = STORE.read(entry)
    if body is None:
        return None
    try:
        return _decode(json.loads(body))
    except (ValueError, TypeError, KeyError, IndexError):
        return None


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
