"""Frozen dataclasses as JSON data and back, following their type hints.

The compiled-system file (:mod:`fmionnx.compile.systemfile`) and the entries kept in the
cache folder (:mod:`fmionnx.kinds.mujoco.keptfacts`) write dataclasses this way: the codec
follows the classes' type hints, so a field added to a class is written and read without
touching the codec, and reading checks every value against its hint (JSON from elsewhere is
never believed). A decoding error names where in the document the value that does not fit
is, and what was expected.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import sys
import types
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from fmionnx.core.errors import FmionnxError


class CodecError(FmionnxError):
    """JSON data that does not fit the class it is read as."""


#: Picks the class a JSON object is read as, for a hint that is a base class: (hint, data,
#: where) -> the class (e.g. a kind's config, named by the object's ``kind``).
Resolver = Callable[[type, dict[str, Any], str], type]


class Codec:
    """Encode and decode dataclasses of one document kind (``what`` names it in messages).

    ``names``: names the classes import only for type checking, which their hints need;
    ``error``: the exception raised for data that does not fit; ``resolve``: the classes
    read through a base class (see :data:`Resolver`), by base.
    """

    def __init__(
        self,
        what: str,
        *,
        names: Mapping[str, Any] | None = None,
        error: Callable[[str], Exception] = CodecError,
        resolve: Mapping[type, Resolver] | None = None,
    ) -> None:
        self.what = what
        self._names = dict(names or {})
        self._error = error
        self._resolve = dict(resolve or {})
        self._hints: dict[type, dict[str, Any]] = {}

    # -- encoding -------------------------------------------------------------------------------

    def encode(self, value: Any) -> Any:
        """``value`` (dataclasses, enums, paths, tuples, mappings, scalars) as JSON data."""
        if value is None or isinstance(value, bool | int | float | str):
            return value
        if isinstance(value, enum.Enum):
            return value.value
        if isinstance(value, Path):
            return value.as_posix()
        if isinstance(value, tuple | list):
            return [self.encode(v) for v in value]
        if isinstance(value, Mapping):
            return {str(k): self.encode(v) for k, v in value.items()}
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: self.encode(getattr(value, f.name)) for f in dataclasses.fields(value)}
        msg = f"cannot serialise a {type(value).__name__} in a {self.what}"
        raise TypeError(msg)

    # -- decoding -------------------------------------------------------------------------------

    def decode(self, hint: Any, data: Any, where: str) -> Any:
        """JSON ``data`` read back as ``hint`` says (the inverse of :meth:`encode`); raises
        the codec's error naming what does not fit and where (RecursionError for data nested
        beyond the interpreter's limit: the caller says so in its own words)."""
        origin = typing.get_origin(hint)
        args = typing.get_args(hint)
        if hint is Any or hint is object:
            return data
        if origin is typing.Union or origin is types.UnionType:
            return self._decode_union(args, data, where)
        if origin is typing.Literal:
            if data not in args:
                raise self.bad(where, f"one of {args}", data)
            return data
        if origin is tuple:
            if not isinstance(data, list):
                raise self.bad(where, "a list", data)
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(
                    self.decode(args[0], item, f"{where}[{i}]") for i, item in enumerate(data)
                )
            if len(args) != len(data):
                raise self.bad(where, f"{len(args)} items", data)
            return tuple(
                self.decode(a, item, f"{where}[{i}]")
                for i, (a, item) in enumerate(zip(args, data, strict=True))
            )
        if isinstance(hint, type):
            return self._decode_class(hint, data, where)
        msg = f"{where}: unsupported type {hint!r} in the {self.what}"
        raise self._error(msg)

    def bad(self, where: str, expected: str, got: Any) -> Exception:
        """The error for ``got`` at ``where`` where ``expected`` was."""
        shown = json.dumps(got)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        return self._error(f"{where}: expected {expected}, got {shown}")

    def _hints_of(self, cls: type) -> dict[str, Any]:
        """The resolved type hints of ``cls``, once per class: resolving evaluates every
        annotation's text, and a document has hundreds of objects of a few classes."""
        found = self._hints.get(cls)
        if found is None:
            module = sys.modules[cls.__module__]
            found = typing.get_type_hints(cls, globalns=vars(module), localns=self._names)
            self._hints[cls] = found
        return found

    def _decode_union(self, args: tuple[Any, ...], data: Any, where: str) -> Any:
        if data is None:
            if type(None) in args:
                return None
            raise self.bad(where, "a value", data)
        plain = [a for a in args if a is not type(None)]
        for option in plain:  # a JSON scalar keeps its own type (bool before int, int before float)
            if (
                isinstance(option, type)
                and option in (bool, int, float, str)
                and type(data) is option
            ):
                return data
        if isinstance(data, int) and not isinstance(data, bool) and float in plain:
            return float(data)
        for option in plain:
            try:
                return self.decode(option, data, where)
            except (FmionnxError, TypeError, ValueError, KeyError):
                continue
        raise self.bad(where, " or ".join(str(a) for a in plain), data)

    def _decode_class(self, cls: type, data: Any, where: str) -> Any:
        if cls is bool:
            if not isinstance(data, bool):
                raise self.bad(where, "true or false", data)
            return data
        if cls is int:
            if not isinstance(data, int) or isinstance(data, bool):
                raise self.bad(where, "an integer", data)
            return data
        if cls is float:
            if not isinstance(data, int | float) or isinstance(data, bool):
                raise self.bad(where, "a number", data)
            return float(data)
        if cls is str:
            if not isinstance(data, str):
                raise self.bad(where, "a string", data)
            return data
        if issubclass(cls, enum.Enum):
            try:
                return cls(data)
            except ValueError:
                raise self.bad(where, f"one of {[m.value for m in cls]}", data) from None
        if issubclass(cls, Path):
            if not isinstance(data, str):
                raise self.bad(where, "a path", data)
            return Path(data)
        if dataclasses.is_dataclass(cls):
            if not isinstance(data, dict):
                raise self.bad(where, "an object", data)
            resolve = self._resolve.get(cls)
            if resolve is not None:
                cls = resolve(cls, data, where)
            hints = self._hints_of(cls)
            known = {f.name for f in dataclasses.fields(cls) if f.init}
            unknown = sorted(set(data) - known)
            if unknown:  # also what tells apart the members of a union of dataclasses
                msg = f"{where}.{unknown[0]}: unknown field of {cls.__name__}"
                raise self._error(msg)
            values = {}
            for f in dataclasses.fields(cls):
                if not f.init:
                    continue
                if f.name not in data:
                    if (
                        f.default is dataclasses.MISSING
                        and f.default_factory is dataclasses.MISSING
                    ):
                        raise self.bad(f"{where}.{f.name}", "a value", None)
                    continue
                values[f.name] = self.decode(hints[f.name], data[f.name], f"{where}.{f.name}")
            return cls(**values)
        msg = f"{where}: unsupported type {cls.__name__} in the {self.what}"
        raise self._error(msg)
