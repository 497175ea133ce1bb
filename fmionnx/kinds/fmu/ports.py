"""Turn an fmpy ``ModelDescription`` into fmionnx ports.

Rules (documented in ``docs/components.md``):

* Causalities ``input``, ``output``, ``parameter``, ``calculatedParameter`` and
  ``structuralParameter`` become ports; ``local`` and ``independent`` do not. FMI 3 clocks are
  not data and are skipped. An FMI 3 ``<Alias>`` of a port variable is a port of its own,
  right after it: same value reference, type, shape, causality and unit, its own name and
  description (as FMPy records it); reading it reads the aliased variable.
* FMI 2 has no arrays, so exporters write ``v[1]`` .. ``v[n]`` as scalars. Scalars
  ``base[i]`` (or ``base[i,j]``) that share type, causality, variability and unit and fill a
  complete 1-based index box become ONE port ``base`` of shape ``(n,)`` (or ``(n, m)``) whose
  ``vrs`` hold the value references in row-major element order. Anything else stays scalar.
* FMI 3 arrays take their shape from ``<Dimension>`` (a fixed ``start`` or the start value of
  the structural parameter it references) and keep their single value reference. The element
  count is checked against :data:`fmionnx.core.resources.ARRAY_ELEMENTS` before anything is
  sized from it (E008): a few bytes of XML can declare an array of 10^9 elements.
* A structural parameter that is an array port's ``<Dimension valueReference=..>`` sizes it:
  :func:`sizing_facts` lists such ports per parameter (facts ``sizes.<parameter>``), because
  the compiled ports keep the shape of the parameter's start value and a value that changes
  it must be refused where it is set.
* Units: a variable's ``unit`` (or its declared type's) names a ``<UnitDefinitions>`` entry;
  its ``<BaseUnit>`` (SI exponents, factor, offset; the same element and attributes in FMI 2
  and 3) becomes the port's unit definition. A unit without ``<BaseUnit>`` is not related to
  SI and stays a name. ``relativeQuantity`` (the variable's, else its type's) is kept.
* ``depends_on`` of an output lists the input ports it depends on per ``<ModelStructure>``;
  it is None (unknown) when the output is not listed or has no ``dependencies`` attribute.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span
from fmionnx.core.errors import ModelError
from fmionnx.core.resources import ARRAY_ELEMENTS
from fmionnx.core.types import Causality, DType, Port, Scalar
from fmionnx.core.units import BASE_UNITS, Unit

#: FMI type name -> element type. FMI 2 enumerations are read with ``fmi2GetInteger`` (int32),
#: FMI 3 enumerations with ``fmi3GetInt64``; see :func:`dtype_of`.
FMI_DTYPES: dict[str, DType] = {
    # FMI 2.0 (section 2.2.7)
    "Real": DType.FLOAT64,
    "Integer": DType.INT32,
    "Boolean": DType.BOOL,
    "String": DType.STRING,
    # FMI 3.0 (section 2.4.7)
    "Float64": DType.FLOAT64,
    "Float32": DType.FLOAT32,
    "Int8": DType.INT8,
    "Int16": DType.INT16,
    "Int32": DType.INT32,
    "Int64": DType.INT64,
    "UInt8": DType.UINT8,
    "UInt16": DType.UINT16,
    "UInt32": DType.UINT32,
    "UInt64": DType.UINT64,
    "Binary": DType.BINARY,
}

#: Causalities that become ports.
PORT_CAUSALITIES = frozenset(
    {"input", "output", "parameter", "calculatedParameter", "structuralParameter"}
)

#: A fact ``sizes.<parameter>`` = ``["port", ...]`` (JSON): the ports whose shape it sets.
SIZES_PREFIX = "sizes."

_INDEXED = re.compile(r"^(?P<base>.+)\[(?P<index>\d+(?:\s*,\s*\d+)*)\]$")


def dtype_of(fmi_type: str, fmi_major: int) -> DType | None:
    """The element type of an FMI variable type, or None for types that are not data."""
    if fmi_type == "Enumeration":
        return DType.INT32 if fmi_major < 3 else DType.INT64
    return FMI_DTYPES.get(fmi_type)


@dataclass(frozen=True, slots=True)
class _Scalarish:
    """One model variable on its way to becoming (part of) a port."""

    variable: Any
    name: str
    causality: Causality
    dtype: DType
    shape: tuple[int, ...]
    unit: str | None
    start: tuple[Scalar, ...] | None
    vrs: tuple[int, ...]
    line: int
    unit_definition: Unit | None = None
    relative_quantity: bool = False
    #: An alias's own description (None: the variable's).
    description: str | None = None
    bounds: tuple[float | None, float | None] = (None, None)


def unit_definitions(model_description: Any) -> dict[str, Unit]:
    """The model's units that relate to SI (those with a ``<BaseUnit>``), by name."""
    units: dict[str, Unit] = {}
    for unit in getattr(model_description, "unitDefinitions", None) or ():
        base = unit.baseUnit
        if unit.name is None or base is None:
            continue
        exponents = tuple(int(getattr(base, name, 0) or 0) for name in BASE_UNITS)
        factor = float(base.factor if base.factor is not None else 1.0)
        offset = float(base.offset if base.offset is not None else 0.0)
        if factor == 0.0 or not (math.isfinite(factor) and math.isfinite(offset)):
            continue  # no usable definition: the name alone is compared
        units[str(unit.name)] = Unit(str(unit.name), exponents, factor, offset)
    return units


#: Attributes read from each variable's own XML element, where fmpy does not read them:
#: ``relativeQuantity`` (fmpy looks for it among the element's children, not on it) and
#: ``min``/``max`` (fmpy reads them for ``Float*``/``Int*``/``Real`` types only, not for
#: FMI 3's ``UInt8``..``UInt64``).
_OWN_ATTRIBUTES = ("relativeQuantity", "min", "max")

#: A variable's attributes of :data:`_OWN_ATTRIBUTES` as it writes them, by variable name.
OwnAttributes = dict[str, dict[str, str]]


def own_attributes(root: Any) -> OwnAttributes:
    """Each variable's :data:`_OWN_ATTRIBUTES` as written in the XML itself (absent: not
    listed). FMI 2 writes them on the type element inside the ``ScalarVariable``."""
    found: OwnAttributes = {}
    variables = root.find("ModelVariables")
    for variable in variables if variables is not None else ():
        if not isinstance(variable.tag, str):
            continue  # a comment
        name = variable.get("name")
        holder = variable
        if variable.tag == "ScalarVariable":  # FMI 2: on the type element inside
            holder = next((c for c in variable if isinstance(c.tag, str)), None)
        if name is None or holder is None:
            continue
        written = {key: text for key in _OWN_ATTRIBUTES if (text := holder.get(key)) is not None}
        if written:
            found[name] = written
    return found


def _relative(variable: Any, own: OwnAttributes) -> bool:
    """FMI ``relativeQuantity`` of the variable, else of its declared type."""
    text = own.get(str(variable.name), {}).get("relativeQuantity")
    if text is not None:
        return text in ("true", "1")
    declared = variable.declaredType
    return bool(getattr(declared, "relativeQuantity", False)) if declared is not None else False


def ports_from_model_description(
    model_description: Any, xml_file: Path, root: Any = None
) -> tuple[Port, ...]:
    """Every port of the model, in declaration order (a group sits at its first element).

    ``root`` is the parsed XML of the same description, for what fmpy does not read
    (:func:`own_attributes`); without it, only type definitions mark relative quantities and
    FMI 3 unsigned integers have only their declared types' bounds.
    """
    major = int(str(model_description.fmiVersion).split(".")[0])
    units = unit_definitions(model_description)
    own = own_attributes(root) if root is not None else {}
    records = [
        record
        for variable in model_description.modelVariables
        if (record := _record(variable, major, xml_file, (units, own))) is not None
    ]
    groups = _groups(records) if major == 2 else {}
    port_name = {id(r.variable): r.name for r in records}
    for base, members in groups.items():
        for member in members:
            port_name[id(member.variable)] = base
    outputs = {id(u.variable): u for u in model_description.outputs}

    ports: list[Port] = []
    emitted: set[str] = set()
    grouped_base = {id(m.variable): base for base, ms in groups.items() for m in ms}
    for record in records:
        group = grouped_base.get(id(record.variable))
        if group is None:
            depends = _depends_on([record], outputs, port_name)
            ports.append(_port(record.name, [record], depends, xml_file))
            for alias in _aliases(record, major):
                ports.append(_port(alias.name, [alias], depends, xml_file))
        elif group not in emitted:
            emitted.add(group)
            depends = _depends_on(groups[group], outputs, port_name)
            ports.append(_port(group, groups[group], depends, xml_file))
    return tuple(ports)


def sizing_facts(model_description: Any) -> tuple[tuple[str, str], ...]:
    """``sizes.<parameter>`` facts: per variable that is a port's ``<Dimension
    valueReference>``, the ports it sizes, in declaration order (an FMI 3 ``<Alias>`` of either
    side is a port of its own, so it is listed and keyed too). None for FMI 2, which has no
    arrays of its own."""
    sized: dict[str, dict[str, None]] = {}
    for variable in model_description.modelVariables:
        if variable.causality not in PORT_CAUSALITIES or dtype_of(variable.type, 3) is None:
            continue
        ports = (str(variable.name), *_alias_names(variable))
        for dimension in getattr(variable, "dimensions", None) or ():
            sizer = dimension.variable  # None: a fixed `start`
            if sizer is None:
                continue
            for name in (str(sizer.name), *_alias_names(sizer)):
                sized.setdefault(name, {}).update(dict.fromkeys(ports))
    # JSON: a variable's name may hold a comma (`a[1,2]`, a quoted Modelica name)
    return tuple((SIZES_PREFIX + name, json.dumps(list(ports))) for name, ports in sized.items())


def _alias_names(variable: Any) -> tuple[str, ...]:
    return tuple(str(a.name) for a in getattr(variable, "aliases", None) or () if a.name)


def _record(
    variable: Any, major: int, xml_file: Path, unit_facts: tuple[dict[str, Unit], OwnAttributes]
) -> _Scalarish | None:
    if variable.causality not in PORT_CAUSALITIES or getattr(variable, "alias", None) is not None:
        return None
    dtype = dtype_of(variable.type, major)
    if dtype is None:  # FMI 3 Clock: an event, not a value
        return None
    shape = tuple(int(d) for d in (variable.shape or ()))
    line = int(variable.sourceline or 0)
    _check_shape(variable, shape, xml_file, line)
    unit: str | None = variable.unit
    if unit is None and variable.declaredType is not None:
        unit = variable.declaredType.unit
    start = _parse_start(variable, dtype, shape, xml_file, line)
    return _Scalarish(
        variable=variable,
        name=str(variable.name),
        causality=Causality(variable.causality),
        dtype=dtype,
        shape=shape,
        unit=unit,
        start=start,
        vrs=(int(variable.valueReference),),
        line=line,
        unit_definition=unit_facts[0].get(unit) if unit is not None else None,
        relative_quantity=_relative(variable, unit_facts[1]),
        bounds=(
            _bound(variable, "min", dtype, unit_facts[1]),
            _bound(variable, "max", dtype, unit_facts[1]),
        ),
    )


def _bound(variable: Any, which: str, dtype: DType, own: OwnAttributes) -> float | None:
    """The variable's declared ``min`` or ``max``, else its declared type's (FMI: the
    variable's attribute overrides the type's); None where neither declares one."""
    text = getattr(variable, which, None)
    if text is None:  # fmpy reads no bound of FMI 3 unsigned integers: the XML's own
        text = own.get(str(variable.name), {}).get(which)
    if text is None and variable.declaredType is not None:
        text = getattr(variable.declaredType, which, None)
    if text is None:
        return None
    try:
        return int(text) if dtype.is_integer else float(text)
    except ValueError:  # the schema check let it through: no bound rather than a wrong one
        return None


def _aliases(record: _Scalarish, major: int) -> list[_Scalarish]:
    """The FMI 3 ``<Alias>`` names of a port variable, each a record of the same variable."""
    if major < 3:
        return []  # FMI 2 aliases are variables of their own, sharing a value reference
    return [
        replace(record, name=str(alias.name), description=alias.description or "")
        for alias in getattr(record.variable, "aliases", None) or ()
        if alias.name
    ]


def _check_shape(variable: Any, shape: tuple[int, ...], xml_file: Path, line: int) -> None:
    """E012 for a negative dimension, E008 for more elements than the limit allows."""
    if any(d < 0 for d in shape):
        msg = f"{xml_file}:{line}: `{variable.name}` has a negative dimension {list(shape)}"
        raise ModelError(codes.BAD_MODEL, msg)
    elements = math.prod(shape)
    if elements > ARRAY_ELEMENTS.value():
        msg = (
            f"{xml_file}:{line}: `{variable.name}` declares {elements} elements "
            f"(dimensions {list(shape)})"
        )
        raise ARRAY_ELEMENTS.exceeded(msg)


def _parse_start(
    variable: Any, dtype: DType, shape: tuple[int, ...], xml_file: Path, line: int
) -> tuple[Scalar, ...] | None:
    text = variable.start
    if text is None:
        return None
    if dtype in (DType.STRING, DType.BINARY):
        return (str(text),)
    try:
        values = tuple(_scalar(token, dtype) for token in str(text).split())
    except ValueError:
        msg = f"{xml_file}:{line}: start value `{text}` of `{variable.name}` is not a {dtype}"
        raise ModelError(codes.BAD_MODEL, msg) from None
    size = math.prod(shape)
    if len(values) == 1 and size > 1:  # one value for a whole FMI 3 array
        values = values * size
    return values


def _scalar(token: str, dtype: DType) -> Scalar:
    if dtype is DType.BOOL:
        if token in ("true", "1"):
            return True
        if token in ("false", "0"):
            return False
        raise ValueError(token)
    if dtype.is_integer:
        return int(token)
    return float(token)


def _groups(records: list[_Scalarish]) -> dict[str, list[_Scalarish]]:
    """FMI 2 indexed scalars that form one array port, by base name (members row-major)."""
    plain = {r.name for r in records}
    candidates: dict[str, list[tuple[tuple[int, ...], _Scalarish]]] = {}
    for record in records:
        match = _INDEXED.match(record.name)
        if match is None or record.shape:
            continue
        index = tuple(int(i) for i in match["index"].split(","))
        candidates.setdefault(match["base"], []).append((index, record))
    groups: dict[str, list[_Scalarish]] = {}
    for base, members in candidates.items():
        if base in plain:
            continue
        members.sort(key=lambda item: item[0])
        if _is_full_box([index for index, _ in members]) and _uniform([r for _, r in members]):
            groups[base] = [record for _, record in members]
    return groups


def _is_full_box(indices: list[tuple[int, ...]]) -> bool:
    """True when the 1-based indices are exactly every element of some n x m x ... box."""
    ranks = {len(index) for index in indices}
    if len(ranks) != 1:
        return False
    rank = ranks.pop()
    extents = [max(index[axis] for index in indices) for axis in range(rank)]
    if math.prod(extents) != len(indices):  # before listing the box: `v[1000000000]` alone
        return False
    expected = list(itertools.product(*(range(1, n + 1) for n in extents)))
    return indices == expected


def _uniform(members: list[_Scalarish]) -> bool:
    first = members[0]
    return all(
        (m.dtype, m.causality, m.variable.variability, m.unit, m.relative_quantity)
        == (
            first.dtype,
            first.causality,
            first.variable.variability,
            first.unit,
            first.relative_quantity,
        )
        for m in members
    )


def _group_shape(members: list[_Scalarish]) -> tuple[int, ...]:
    match = _INDEXED.match(members[-1].name)
    if match is None:  # a single scalar, never grouped
        return ()
    return tuple(int(i) for i in match["index"].split(","))


def _depends_on(
    members: list[_Scalarish], outputs: dict[int, Any], port_name: dict[int, str]
) -> tuple[str, ...] | None:
    if members[0].causality is not Causality.OUTPUT:
        return None
    names: dict[str, None] = {}
    for member in members:
        unknown = outputs.get(id(member.variable))
        if unknown is None or unknown.dependencies is None:
            return None
        for dependency in unknown.dependencies:
            if dependency.causality == "input" and id(dependency) in port_name:
                names[port_name[id(dependency)]] = None
    return tuple(names)


def _port(
    name: str,
    members: list[_Scalarish],
    depends_on: tuple[str, ...] | None,
    xml_file: Path,
) -> Port:
    first = members[0]
    grouped = len(members) > 1 or name != first.name
    start: tuple[Scalar, ...] | None
    if all(m.start is not None for m in members):
        start = tuple(itertools.chain.from_iterable(m.start or () for m in members))
    else:
        start = None
    return Port(
        name=name,
        causality=first.causality,
        dtype=first.dtype,
        shape=_group_shape(members) if grouped else first.shape,
        unit=first.unit,
        start=start,
        variability=first.variable.variability,
        description=(
            first.description if first.description is not None else first.variable.description or ""
        ),
        depends_on=depends_on,
        vrs=tuple(itertools.chain.from_iterable(m.vrs for m in members)),
        origin=Span(xml_file, first.line),
        unit_definition=first.unit_definition,
        relative_quantity=first.relative_quantity,
        # A group's elements each declare their own; one pair only when all agree.
        bounds=first.bounds if all(m.bounds == first.bounds for m in members) else (None, None),
    )
