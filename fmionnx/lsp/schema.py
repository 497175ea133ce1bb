"""The keys and fixed values the file formats allow at a key path, read from the pydantic
models that define the formats (the same models the JSON Schema is exported from).

A component entry's keys depend on its ``kind``: the entry's kind (when the file says) picks
the kind's model; without one, the keys every kind has.
"""

from __future__ import annotations

import types as pytypes
import typing
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Literal, Union

from pydantic import BaseModel

from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.lsp.yamlcontext import ITEM


@dataclass(frozen=True, slots=True)
class Key:
    """A key a mapping may have, with its description."""

    name: str
    description: str
    required: bool


#: A value that is neither a mapping nor a list (a string, a number, a boolean).
SCALAR = "scalar"


@dataclass(frozen=True, slots=True)
class _MapOf:
    """``dict[str, X]``: any key, each value an ``X``."""

    value: Any


@dataclass(frozen=True, slots=True)
class _ListOf:
    """``list[X]``: each entry an ``X``."""

    value: Any


def _expand(annotation: Any) -> Iterator[Any]:
    """The models, mappings, lists and literals an annotation may be."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        yield from _expand(typing.get_args(annotation)[0])
    elif origin in (Union, pytypes.UnionType):
        for member in typing.get_args(annotation):
            yield from _expand(member)
    elif origin is dict:
        yield _MapOf(typing.get_args(annotation)[1])
    elif origin in (list, tuple):
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        yield _ListOf(args[0] if args else Any)
    elif origin is Literal or (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
        yield annotation
    else:
        yield SCALAR


def _field(model: type[BaseModel], key: str) -> Any:
    for name, info in model.model_fields.items():
        if key in (name, info.alias):
            return info.annotation, info
    return None


KindOf = Callable[[str], str | None]


def _step(shapes: list[Any], segment: str, kind_of: KindOf, component: str | None) -> list[Any]:
    found: list[Any] = []
    for shape in shapes:
        if isinstance(shape, type) and issubclass(shape, BaseModel) and segment != ITEM:
            entry = _field(shape, segment)
            if entry is not None:
                found.extend(_expand(entry[0]))
        elif isinstance(shape, _MapOf) and segment != ITEM:
            found.extend(
                _narrow(list(_expand(shape.value)), kind_of, segment if component else None)
            )
        elif isinstance(shape, _ListOf) and segment == ITEM:
            found.extend(_expand(shape.value))
    return found


def _narrow(shapes: list[Any], kind_of: KindOf, name: str | None) -> list[Any]:
    """A component entry's model by its kind (every kind's when it names none)."""
    if name is None:
        return shapes
    kind = kind_of(name)
    models = [s for s in shapes if isinstance(s, type) and issubclass(s, ComponentSpecBase)]
    if not models:
        return shapes
    if kind is not None and kind in COMPONENT_KINDS:
        chosen = COMPONENT_KINDS[kind].spec_model
        return [chosen]
    return [ComponentSpecBase]


def shapes_at(root: type[BaseModel], path: tuple[str, ...], kind_of: KindOf) -> list[Any]:
    """What may be written at ``path`` of a file whose model is ``root``."""
    shapes: list[Any] = [root]
    for index, segment in enumerate(path):
        component = segment if index == 1 and path[0] == "components" else None
        shapes = _step(shapes, segment, kind_of, component)
        if not shapes:
            break
    return shapes


def keys_at(root: type[BaseModel], path: tuple[str, ...], kind_of: KindOf) -> list[Key]:
    """The keys of the mapping at ``path`` (none when it is not a mapping of fixed keys)."""
    keys: dict[str, Key] = {}
    for shape in shapes_at(root, path, kind_of):
        if isinstance(shape, type) and issubclass(shape, BaseModel):
            for name, info in shape.model_fields.items():
                shown = info.alias or name
                if shown not in keys:
                    keys[shown] = Key(shown, info.description or "", info.is_required())
    return list(keys.values())


def values_at(root: type[BaseModel], path: tuple[str, ...], kind_of: KindOf) -> list[str]:
    """The fixed values (``Literal`` choices) the value at ``path`` may take."""
    values: list[str] = []
    for shape in shapes_at(root, path, kind_of):
        if typing.get_origin(shape) is Literal:
            values.extend(str(v) for v in typing.get_args(shape) if str(v) not in values)
    return values


def key_description(
    root: type[BaseModel], path: tuple[str, ...], key: str, kind_of: KindOf
) -> str | None:
    """The description of ``key`` in the mapping at ``path``, or None when it is no key there."""
    for found in keys_at(root, path, kind_of):
        if found.name == key:
            return found.description
    return None


def takes_mappings_only(root: type[BaseModel], path: tuple[str, ...], kind_of: KindOf) -> bool:
    """True when every form of the value at ``path`` is a mapping of fixed keys (a list entry
    of ``checks`` or ``plots``), so what is typed there is a key."""
    shapes = shapes_at(root, path, kind_of)
    return bool(shapes) and all(isinstance(s, type) and issubclass(s, BaseModel) for s in shapes)
