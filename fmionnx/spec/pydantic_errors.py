"""Turn pydantic validation errors into positioned diagnostics with "did you mean" hints.

Pydantic reports ``loc`` tuples such as ``("components", "odometry", "fmu", "perid")``; we map
them to spans through the :class:`SourceMap` and, for unknown keys, find the model that was
being validated to suggest the closest valid key.
"""

from __future__ import annotations

import re
import types
import typing
from typing import Any

from pydantic import BaseModel, ValidationError

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, did_you_mean, one_of
from fmionnx.spec.sourcemap import SourceMap


def report_validation_error(
    exc: ValidationError,
    data: Any,
    sources: SourceMap,
    bag: DiagnosticBag,
    root: type[BaseModel] | None = None,
) -> None:
    """Add one diagnostic per pydantic error (unions reported once, on their best branch)."""
    if root is None:
        from fmionnx.spec.model import SystemSpec

        root = SystemSpec
    seen: set[tuple[Any, ...]] = set()
    errors = exc.errors(include_url=False)
    paths = [_data_path(tuple(error["loc"]), data) for error in errors]
    for error, data_loc in zip(errors, paths, strict=True):
        loc = tuple(error["loc"])
        kind = error["type"]
        if _other_union_branch(loc, data) or _scalar_beside_deeper(loc, data_loc, paths, data):
            continue
        if kind in {"extra_forbidden", "missing"} or data_loc not in seen:
            _emit(error, loc, data_loc, data, sources, bag, root)
        seen.add(data_loc)


def _emit(
    error: Any,
    loc: tuple[Any, ...],
    data_loc: tuple[Any, ...],
    data: Any,
    sources: SourceMap,
    bag: DiagnosticBag,
    root: type[BaseModel],
) -> None:
    kind = error["type"]
    where = _dotted(data_loc)
    if kind == "extra_forbidden":
        key = str(data_loc[-1])
        model = _model_at(root, loc[:-1])
        fields = _field_names(model) if model is not None else []
        hint = did_you_mean(key, fields) or (one_of(fields) if fields else None)
        owner = _dotted(data_loc[:-1]) or "the top level"
        bag.emit(
            codes.UNKNOWN_KEY, f"unknown key `{key}` in {owner}", sources.key(data_loc), hint=hint
        )
        return
    if kind == "missing":
        key = str(data_loc[-1])
        owner = _dotted(data_loc[:-1]) or "the top level"
        bag.emit(codes.MISSING_KEY, f"missing key `{key}` in {owner}", sources.key(data_loc[:-1]))
        return
    if kind in {"union_tag_invalid", "union_tag_not_found"}:
        from fmionnx.kinds.registry import COMPONENT_KINDS

        if kind == "union_tag_not_found":
            bag.emit(
                codes.MISSING_KEY,
                f"component `{data_loc[-1]}` has no `kind`",
                sources.key(data_loc),
                hint=one_of(COMPONENT_KINDS),
            )
            return
        value = _value_at(data, (*data_loc, "kind"))
        hint = did_you_mean(str(value), COMPONENT_KINDS) or one_of(COMPONENT_KINDS)
        bag.emit(
            codes.UNKNOWN_KIND,
            f"unknown component kind `{value}`",
            sources.value((*data_loc, "kind")),
            hint=hint,
        )
        return
    if data_loc == ("fmionnx",):
        bag.emit(
            codes.FORMAT_VERSION,
            f"format version `{_short(_value_at(data, data_loc))}` is not supported",
            sources.value(data_loc),
            hint="this release reads `fmionnx: 1`",
        )
        return
    from fmionnx.spec.model import PATTERN_MEANINGS, InvalidKeyError  # as SystemSpec above

    message = str(error.get("msg", "invalid value"))
    message = message.removeprefix("Value error, ")
    value = _value_at(data, data_loc)
    # a whole mapping or list shown as Python's repr helps nobody: the value is at the caret
    scalar = value is not _MISSING and not isinstance(value, (dict, list))
    shown = f" (got {_short(value)})" if scalar else ""
    span = sources.value(data_loc)
    context = error.get("ctx") or {}
    cause = context.get("error")
    if isinstance(cause, InvalidKeyError):  # the key itself is wrong: point at it
        bag.emit(
            codes.INVALID_VALUE,
            f"`{where}`: {message}",
            sources.key((*data_loc, cause.key)),
            hint=f"e.g. `{_as_name(cause.key)}`",
        )
        return
    if kind in _MAPPING_EXPECTED:
        written, example = _WRITTEN_AS.get(
            str(context.get("class_name")), ("a mapping (`key: value` pairs)", "`key: value`")
        )
        bag.emit(
            codes.INVALID_VALUE, f"`{where}` must be {written}{shown}", span, hint=f"e.g. {example}"
        )
        return
    if kind == "string_pattern_mismatch":
        pattern = str(context.get("pattern", ""))
        meaning = PATTERN_MEANINGS.get(pattern, f"text of the form `{pattern}`")
        hint = f"e.g. `{_as_name(str(value), dots=False)}`" if pattern in PATTERN_MEANINGS else None
        bag.emit(codes.INVALID_VALUE, f"`{where}` must be {meaning}{shown}", span, hint=hint)
        return
    bag.emit(codes.INVALID_VALUE, f"`{where}`: {message}{shown}", span)


#: pydantic error types that mean "a mapping was expected here".
_MAPPING_EXPECTED = frozenset({"model_type", "model_attributes_type", "dict_type"})
#: How an entry of each model is written, for "must be ..." (pydantic names the class), and
#: an example for the hint.
_WRITTEN_AS = {
    "ConnectionSpec": (
        "a connection: `source.port -> target.port`, or a mapping `{from: ..., to: ...}`",
        "`- plant.y -> controller.u`",
    ),
    "RunSpec": ("the run settings: a mapping", "`run: {stop: 10, step: 0.01}`"),
    "PlotSpec": ("a plot: a mapping of the signals it draws", "`- {y: [plant.y]}`"),
    "CheckSpec": (
        "a check: a mapping with `expect` (and a `name`)",
        "`- {name: settles, expect: abs(final(plant.y) - 1) < 0.01}`",
    ),
}


def _as_name(text: str, *, dots: bool = True) -> str:
    """``text`` made a valid name: other characters become ``_``, a leading digit gets one.

    ``dots``: whether the name may be dotted (components, system inputs) or not (a system).
    """
    name = re.sub(r"[^\w.-]+" if dots else r"[^\w-]+", "_", text.strip()) or "_"
    return name if re.match(r"[A-Za-z_]", name) else f"_{name}"


_MISSING = object()


def _short(value: Any) -> str:
    """``value`` as the YAML writes it where that differs from Python (``null``, ``true``),
    cut to 40 characters."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _dotted(path: tuple[Any, ...]) -> str:
    text = ""
    for element in path:
        if isinstance(element, int):
            text += f"[{element}]"
        else:
            text += ("." if text else "") + str(element)
    return text


def _value_at(data: Any, path: tuple[Any, ...]) -> Any:
    current = data
    for element in path:
        if (isinstance(current, dict) and element in current) or (
            isinstance(current, list) and isinstance(element, int) and element < len(current)
        ):
            current = current[element]
        else:
            return _MISSING
    return current


def _data_path(loc: tuple[Any, ...], data: Any) -> tuple[Any, ...]:
    """Drop loc elements that are not in the data (union tags, type names like `str`)."""
    path: list[Any] = []
    current = data
    for element in loc:
        if (isinstance(current, dict) and element in current) or (
            isinstance(current, list) and isinstance(element, int) and element < len(current)
        ):
            path.append(element)
            current = current[element]
        elif isinstance(current, dict) and element not in current and _is_last_key(loc, element):
            path.append(element)
    return tuple(path)


def _other_union_branch(loc: tuple[Any, ...], data: Any) -> bool:
    """True for an error of the `str` branch of a `str | Model` union whose value is a map."""
    for position, element in enumerate(loc):
        if element == "str":
            return not isinstance(_value_at(data, _data_path(loc[:position], data)), str)
    return False


#: The names pydantic gives the scalar branches of a union in an error's ``loc``.
_SCALAR_BRANCHES = frozenset({"bool", "int", "float", "str"})


def _scalar_beside_deeper(
    loc: tuple[Any, ...], data_loc: tuple[Any, ...], paths: list[tuple[Any, ...]], data: Any
) -> bool:
    """True for a scalar branch's complaint about a list or mapping when another error lies
    inside that value: the container branch was tried and says what is wrong there. For
    ``[[1, null]]`` "Input should be a valid boolean" at ``[0]`` came beside "null is not a
    value" at ``[0][1]`` (a bug hunt). Without a deeper error it is kept: it is then the
    only word on a list written where a scalar belongs."""
    if not loc or loc[-1] not in _SCALAR_BRANCHES:
        return False
    if not isinstance(_value_at(data, data_loc), (dict, list)):
        return False
    return any(len(p) > len(data_loc) and p[: len(data_loc)] == data_loc for p in paths)


def _is_last_key(loc: tuple[Any, ...], element: Any) -> bool:
    return bool(loc) and loc[-1] == element


def _field_names(model: type[BaseModel]) -> list[str]:
    return [info.alias or name for name, info in model.model_fields.items()]


def _model_at(root: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model class validated at ``loc`` (follows fields, dict values, lists, union tags)."""
    current: Any = root
    for element in loc:
        current = _step(current, element)
        if current is None:
            return None
    models = [m for m in _candidates(current) if isinstance(m, type) and issubclass(m, BaseModel)]
    return models[0] if len(models) == 1 else None


def _step(current: Any, element: Any) -> Any:
    if isinstance(element, str):
        for candidate in _candidates(current):
            if isinstance(candidate, type) and candidate.__name__ == element:
                return candidate
        tagged = _tagged(current, element)
        if tagged is not None:
            return tagged
    for candidate in _candidates(current):
        if isinstance(candidate, type) and issubclass(candidate, BaseModel):
            fields = candidate.model_fields
            for name, info in fields.items():
                if element in {name, info.alias}:
                    return info.annotation
            continue
        origin = typing.get_origin(candidate)
        args = typing.get_args(candidate)
        if origin is dict and isinstance(element, str):
            return args[1]
        if origin in {list, tuple} and isinstance(element, int):
            return args[0]
    return None


def _tagged(candidate: Any, tag: str) -> Any:
    for option in _candidates(candidate):
        if isinstance(option, type) and issubclass(option, BaseModel):
            kind_field = option.model_fields.get("kind")
            if kind_field is not None and kind_field.default == tag:
                return option
    return None


def _candidates(annotation: Any) -> list[Any]:
    """Flatten Optional/Union/Annotated into the list of alternative types."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _candidates(typing.get_args(annotation)[0])
    if origin in {typing.Union, types.UnionType}:
        result: list[Any] = []
        for arg in typing.get_args(annotation):
            result.extend(_candidates(arg))
        return result
    return [annotation]
