"""Parameter values of SSP bindings: inline ``ssv:ParameterSet``, ``.ssv`` files, ``.ssm`` maps.

A binding yields ``(name, value, span)`` entries with the binding's ``prefix`` applied and the
mapping's renames and linear transformations done, ready to be matched against the element the
binding belongs to. Values keep their SSV type: ``Real`` -> float, ``Integer`` -> int,
``Boolean`` -> bool, ``String`` -> str.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlparse

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.specbase import ScalarLiteral
from fmionnx.core.types import ValueSource, is_number
from fmionnx.core.units import BASE_UNITS, Unit, builtin_unit
from fmionnx.spec.ssp_tree import Binding, Transformation
from fmionnx.spec.ssp_xml import parse_xml, tag, validate, validate_inline


@dataclass(frozen=True, slots=True)
class BoundValue:
    """One parameter value from a binding, named as in the bound element."""

    name: str
    value: ScalarLiteral
    span: Span
    #: Where the value was written: ``SSP_INLINE`` or ``SSV_FILE`` (``run.json`` says it).
    origin: ValueSource = ValueSource.SSP_INLINE
    #: It reached the connector along connections from a bound system connector.
    via_connection: bool = False
    #: The unit the value is written in (a Real's ``unit``, defined in the set's
    #: ``ssv:Units``); None: the unit of whatever it sets.
    unit: Unit | None = None


def resolve_uri(
    text: str, base: Path, root: Path | None, span: Span, bag: DiagnosticBag
) -> Path | None:
    """A relative ``source`` URI as a path under ``base``; None (E071/E017) otherwise.

    ``root`` is the unpacked archive, None for a loose ``.ssd``, whose folder (``base``) is
    then the boundary: a resource may not point outside it, links followed, because an SSD
    from a supplier must not make fmionnx read (or load and run) files elsewhere on the
    machine. This is where the file is opened, so the check cannot be skipped.
    """
    parsed = urlparse(text)
    if parsed.scheme or parsed.netloc:
        bag.emit(
            codes.SSP_UNSUPPORTED,
            f"`{text}`: only relative references into the SSP are supported (no URI schemes)",
            span,
        )
        return None
    try:
        path = (base / unquote(parsed.path)).resolve()
    except (ValueError, OSError):
        bag.emit(codes.SSP_REFERENCE, f"`{text}` is not a usable file reference", span)
        return None
    boundary = (root if root is not None else base).resolve()
    if not path.is_relative_to(boundary):
        where = "the SSP archive" if root is not None else "the folder of the .ssd"
        bag.emit(
            codes.UNSAFE_ARCHIVE,
            f"`{text}` points outside {where}",
            span,
            hint="SSP resources are referenced relative to the SSD, inside its archive or folder",
        )
        return None
    try:
        exists, folder = path.is_file(), path.is_dir()
    except OSError:  # a name longer than the file system allows: no such resource either
        exists = folder = False
    if folder:
        bag.emit(
            codes.SSP_REFERENCE,
            f"`{text[:200]}` is a folder in the SSP, not a file",
            span,
            hint="a reference names a file (`resources/model.fmu`), not its folder",
        )
        return None
    if not exists:
        bag.emit(codes.SSP_REFERENCE, f"`{text[:200]}` does not exist in the SSP", span)
        return None
    return path


def _scalar(node: Any, span: Span, bag: DiagnosticBag) -> ScalarLiteral | None:
    for kind in ("Real", "Integer", "Boolean", "String"):
        typed = node.find(tag("ssv", kind))
        if typed is None:
            continue
        text = str(typed.get("value", ""))
        try:
            if kind == "Real":
                return float(text)
            if kind == "Integer":
                return int(text)
        except ValueError:
            bag.emit(codes.INVALID_VALUE, f"`{text}` is not a valid {kind} value", span)
            return None
        if kind == "Boolean":
            return text.strip() in {"true", "1"}
        return text
    bag.emit(
        codes.SSP_UNSUPPORTED,
        "only Real, Integer, Boolean and String parameter values are supported",
        span,
        hint="enumeration and binary values are not supported yet",
    )
    return None


def read_parameter_set(
    element: Any, file: Path, bag: DiagnosticBag, origin: ValueSource = ValueSource.SSP_INLINE
) -> list[BoundValue]:
    """The parameters of a ``ssv:ParameterSet`` element (inline or a file's root)."""
    units = _units(element)
    values = []
    for node in element.iterfind(f"{tag('ssv', 'Parameters')}/{tag('ssv', 'Parameter')}"):
        span = Span(file, node.sourceline)
        value = _scalar(node, span, bag)
        if value is not None:
            unit = _value_unit(node, units, span, bag)
            values.append(BoundValue(node.get("name"), value, span, origin, unit=unit))
    return values


def _units(element: Any) -> dict[str, Unit]:
    """The ``ssv:Units`` of a parameter set: name -> definition (SI exponents, factor, offset)."""
    units: dict[str, Unit] = {}
    for node in element.iterfind(f"{tag('ssv', 'Units')}/{tag('ssc', 'Unit')}"):
        base = node.find(tag("ssc", "BaseUnit"))
        if base is None:
            continue
        exponents = tuple(int(base.get(e, "0")) for e in BASE_UNITS)
        factor = float(base.get("factor", "1"))
        offset = float(base.get("offset", "0"))
        units[node.get("name")] = Unit(node.get("name"), exponents, factor, offset)
    return units


def _value_unit(node: Any, units: dict[str, Unit], span: Span, bag: DiagnosticBag) -> Unit | None:
    """The unit a Real value is written in: defined in the set's ``ssv:Units`` (SSV: it
    MUST be), else a built-in unit of that name; None (W070) for a name neither defines."""
    typed = node.find(tag("ssv", "Real"))
    name = typed.get("unit") if typed is not None else None
    if not name:
        return None
    unit = units.get(name) or builtin_unit(name)
    if unit is None:
        bag.emit(
            codes.SSP_IGNORED,
            f"unit `{name}` of parameter `{node.get('name')}` is not defined in the parameter "
            "set's `ssv:Units`; the value is used as written",
            span,
        )
    return unit


@dataclass(frozen=True, slots=True)
class _Entry:
    target: str
    transformation: Transformation | None
    span: Span


def read_mapping(element: Any, file: Path, bag: DiagnosticBag) -> dict[str, list[_Entry]]:
    """``source name -> entries`` of a ``ssm:ParameterMapping`` element.

    One source may feed several targets (OMSimulator maps one value onto the same connector
    of several systems), so every entry is kept, in file order.
    """
    entries: dict[str, list[_Entry]] = {}
    for node in element.iterfind(tag("ssm", "MappingEntry")):
        span = Span(file, node.sourceline)
        linear = node.find(tag("ssc", "LinearTransformation"))
        transformation = None
        if linear is not None:
            transformation = Transformation(
                float(linear.get("factor", "1")), float(linear.get("offset", "0"))
            )
        elif len(node):
            bag.emit(
                codes.SSP_UNSUPPORTED, "only linear transformations are supported in mappings", span
            )
            continue
        entries.setdefault(node.get("source"), []).append(
            _Entry(node.get("target"), transformation, span)
        )
    return entries


def _apply(value: BoundValue, entry: _Entry | None, bag: DiagnosticBag) -> BoundValue:
    if entry is None:
        return value
    result = value.value
    if entry.transformation is not None:
        if not is_number(result):
            bag.emit(
                codes.SSP_UNSUPPORTED,
                f"a linear transformation applies to Real values, not to `{value.name}`",
                entry.span,
            )
        else:
            result = entry.transformation.factor * result + entry.transformation.offset
    return replace(value, name=entry.target, value=result)


def _load(
    source: str, base: Path, root: Path | None, kind: str, span: Span, bag: DiagnosticBag
) -> tuple[Any, Path] | None:
    path = resolve_uri(source, base, root, span, bag)
    if path is None:
        return None
    tree = parse_xml(path, bag)
    if tree is None or not validate(tree, kind, path, bag):
        return None
    return tree.getroot(), path


def binding_values(
    binding: Binding, ssd: Path, root: Path | None, bag: DiagnosticBag
) -> list[BoundValue]:
    """Every value a binding sets, renamed by its mapping and prefixed by its ``prefix``."""
    span = Span(ssd, binding.line)
    base = ssd.parent
    values: list[BoundValue] = []
    if binding.inline is not None:
        if not validate_inline(binding.inline, "ssv", ssd, bag):
            return []
        values = read_parameter_set(binding.inline, ssd, bag)
    elif binding.source is not None:
        loaded = _load(binding.source, base, root, "ssv", span, bag)
        if loaded is None:
            return []
        values = read_parameter_set(loaded[0], loaded[1], bag, ValueSource.SSV_FILE)
    mapping: dict[str, list[_Entry]] = {}
    if binding.inline_mapping is not None:
        if not validate_inline(binding.inline_mapping, "ssm", ssd, bag):
            return []
        mapping = read_mapping(binding.inline_mapping, ssd, bag)
    elif binding.mapping_source is not None:
        loaded = _load(binding.mapping_source, base, root, "ssm", span, bag)
        if loaded is not None:
            mapping = read_mapping(loaded[0], loaded[1], bag)
    # The prefix is prepended before mapping and name resolution (SSD XSD, `prefix`).
    result: list[BoundValue] = []
    for value in values:
        full = replace(value, name=binding.prefix + value.name)
        entries: list[_Entry | None] = [*mapping.get(full.name, [])] or [None]
        result.extend(_apply(full, entry, bag) for entry in entries)
    return result
