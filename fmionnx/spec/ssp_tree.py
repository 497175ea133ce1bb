"""The SSD read into small typed records, each remembering its line in the file.

This is the parse step only: names stay as written, nothing is resolved. Flattening nested
systems and resolving parameters happen in :mod:`fmionnx.spec.ssp_flatten`. Elements the
reader understands are listed here; everything else is reported by
:func:`report_unread` as ignored (W070) or unsupported (E071).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.spec.ssp_xml import NS as _NS
from fmionnx.spec.ssp_xml import short, tag

#: Our own annotation type: component options and system settings as JSON text.
FMIONNX_ANNOTATION = "org.fmionnx"
#: OMSimulator's annotation type; its ``FixedStepMaster stepSize`` gives the base step.
OMS_ANNOTATION = "org.openmodelica"


@dataclass(frozen=True, slots=True)
class Connector:
    """A connector: name, kind, and the type element's name and unit when given."""

    name: str
    kind: str
    type: str | None
    unit: str | None
    line: int


@dataclass(frozen=True, slots=True)
class Transformation:
    """A ``LinearTransformation`` (the only transformation fmionnx applies)."""

    factor: float
    offset: float


@dataclass(frozen=True, slots=True)
class Connection:
    """A connection inside one system; a missing element means the system's own connector."""

    start_element: str | None
    start_connector: str
    end_element: str | None
    end_connector: str
    transformation: Transformation | None
    suppress_unit_conversion: bool
    line: int


@dataclass(frozen=True, slots=True)
class Binding:
    """A ``ParameterBinding``: an inline set or a ``source`` file, an optional mapping."""

    source: str | None
    inline: Any  # the ssv:ParameterSet element, or None
    prefix: str
    mapping_source: str | None
    inline_mapping: Any  # the ssm:ParameterMapping element, or None
    line: int


@dataclass(frozen=True, slots=True)
class Annotation:
    """One of our ``org.fmionnx`` annotations: its JSON text and where it is."""

    text: str
    line: int


@dataclass(slots=True)
class Element:
    """A component or a system (``children`` and ``connections`` only for systems)."""

    name: str
    is_system: bool
    line: int
    description: str = ""
    type: str = ""
    source: str | None = None
    implementation: str = "any"
    connectors: list[Connector] = field(default_factory=list)
    bindings: list[Binding] = field(default_factory=list)
    annotation: Annotation | None = None
    children: list[Element] = field(default_factory=list)
    connections: list[Connection] = field(default_factory=list)
    #: OMSimulator's fixed step as written (a text that is not a number is kept, for the
    #: spec check to report) and the line of its annotation.
    step: float | str | None = None
    step_line: int = 0


@dataclass(frozen=True, slots=True)
class Unit:
    """An ``ssc:Unit``: SI exponents plus factor and offset (value_SI = factor*x + offset)."""

    exponents: tuple[int, ...]
    factor: float
    offset: float


@dataclass(slots=True)
class Document:
    """The whole SSD."""

    name: str
    version: str
    root: Element
    units: dict[str, Unit]
    start: float | None
    stop: float | None
    annotation: Annotation | None
    line: int


_UNIT_EXPONENTS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration", "Binary")


def _float(element: Any, name: str, default: float) -> float:
    text = element.get(name)
    return float(text) if text is not None else default


def _connectors(element: Any) -> list[Connector]:
    result = []
    for node in element.iterfind("ssd:Connectors/ssd:Connector", namespaces=_NS):
        type_name: str | None = None
        unit: str | None = None
        for name in _TYPES:
            typed = node.find(tag("ssc", name))
            if typed is not None:
                type_name, unit = name, typed.get("unit")
                break
        result.append(
            Connector(node.get("name"), node.get("kind"), type_name, unit, node.sourceline)
        )
    return result


def _annotation(element: Any, path: str) -> tuple[Annotation | None, float | str | None, int]:
    """Our annotation under ``path``, an OMSimulator fixed step if any, and the step's line.

    Other tools' annotations are not covered by the SSD's schema: a step that is not a number
    is kept as written, and the system's schema check reports it at its line.
    """
    ours: Annotation | None = None
    step: float | str | None = None
    line = 0
    for node in element.iterfind(path + "/ssc:Annotation", namespaces=_NS):
        kind = node.get("type")
        if kind == FMIONNX_ANNOTATION:
            text = "".join(child.text or "" for child in node)
            ours = Annotation(text.strip(), node.sourceline)
        elif kind == OMS_ANNOTATION:
            for master in node.iter("{*}FixedStepMaster"):
                size = master.get("stepSize")
                if size is not None:
                    step, line = _number(size), master.sourceline
    return ours, step, line


def _number(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def _bindings(element: Any) -> list[Binding]:
    result = []
    for node in element.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", namespaces=_NS):
        mapping = node.find(tag("ssd", "ParameterMapping"))
        result.append(
            Binding(
                source=node.get("source"),
                inline=node.find("ssd:ParameterValues/ssv:ParameterSet", namespaces=_NS),
                prefix=node.get("prefix") or "",
                mapping_source=mapping.get("source") if mapping is not None else None,
                inline_mapping=(
                    mapping.find(tag("ssm", "ParameterMapping")) if mapping is not None else None
                ),
                line=node.sourceline,
            )
        )
    return result


def _connection(node: Any) -> Connection:
    linear = node.find(tag("ssc", "LinearTransformation"))
    transformation = None
    if linear is not None:
        transformation = Transformation(
            _float(linear, "factor", 1.0), _float(linear, "offset", 0.0)
        )
    return Connection(
        start_element=node.get("startElement"),
        start_connector=node.get("startConnector"),
        end_element=node.get("endElement"),
        end_connector=node.get("endConnector"),
        transformation=transformation,
        suppress_unit_conversion=node.get("suppressUnitConversion") in {"true", "1"},
        line=node.sourceline,
    )


def read_element(node: Any) -> Element:
    """Read a ``ssd:System`` or ``ssd:Component`` (recursively for systems)."""
    is_system = node.tag == tag("ssd", "System")
    element = Element(
        name=node.get("name"),
        is_system=is_system,
        line=node.sourceline,
        description=node.get("description") or "",
    )
    element.connectors = _connectors(node)
    element.bindings = _bindings(node)
    element.annotation, element.step, element.step_line = _annotation(node, "ssd:Annotations")
    if not is_system:
        element.type = node.get("type") or "application/x-fmu-sharedlibrary"
        element.source = node.get("source")
        element.implementation = node.get("implementation") or "any"
        return element
    for child in node.iterfind("ssd:Elements/*", namespaces=_NS):
        if child.tag in (tag("ssd", "System"), tag("ssd", "Component")):
            element.children.append(read_element(child))
    element.connections = [
        _connection(c) for c in node.iterfind("ssd:Connections/ssd:Connection", namespaces=_NS)
    ]
    return element


def read_document(tree: Any) -> Document:
    """Read a validated SSD tree."""
    root = tree.getroot()
    units: dict[str, Unit] = {}
    for node in root.iterfind("ssd:Units/ssc:Unit", namespaces=_NS):
        base = node.find(tag("ssc", "BaseUnit"))
        exponents = tuple(int(base.get(e, "0")) for e in _UNIT_EXPONENTS)
        units[node.get("name")] = Unit(
            exponents, _float(base, "factor", 1.0), _float(base, "offset", 0.0)
        )
    experiment = root.find(tag("ssd", "DefaultExperiment"))
    start = stop = None
    experiment_annotation: Annotation | None = None
    if experiment is not None:
        start = float(experiment.get("startTime")) if experiment.get("startTime") else None
        stop = float(experiment.get("stopTime")) if experiment.get("stopTime") else None
        experiment_annotation, _, _ = _annotation(experiment, "ssd:Annotations")
    annotation, _, _ = _annotation(root, "ssd:Annotations")
    system = read_element(root.find(tag("ssd", "System")))
    return Document(
        name=root.get("name"),
        version=root.get("version"),
        root=system,
        units=units,
        start=start,
        stop=stop,
        annotation=annotation or experiment_annotation,
        line=root.sourceline,
    )


#: Elements read above, by local name; children of these that are not listed are reported.
_UNDERSTOOD = {
    "SystemStructureDescription",
    "System",
    "Component",
    "Elements",
    "Connectors",
    "Connector",
    "Connections",
    "Connection",
    "LinearTransformation",
    "ParameterBindings",
    "ParameterBinding",
    "ParameterValues",
    "ParameterSet",
    "ParameterMapping",
    "Units",
    "Unit",
    "BaseUnit",
    "DefaultExperiment",
    "Annotations",
    "Annotation",
    "Parameters",
    "Parameter",
    "MappingEntry",
    *_TYPES,
}
#: The diagram's layout: every tool writes it, nothing computes with it. One I070 note per
#: file at most (a W070 per element, or per kind, buried every finding that mattered).
_LAYOUT = {
    "ConnectorGeometry",
    "ElementGeometry",
    "ConnectionGeometry",
    "SystemGeometry",
    "GraphicalElements",
}
#: Read and harmlessly ignored (documentation, metadata): W070 once per kind.
_HARMLESS = {
    *_LAYOUT,
    "Enumerations",
    "MetaData",
    "Signature",
}
#: Changes what the system computes; fmionnx cannot honour it yet: E071.
_UNSUPPORTED = {
    "SignalDictionaries": "signal dictionaries",
    "SignalDictionaryReference": "signal dictionary references",
    "BooleanMappingTransformation": "boolean mapping transformations",
    "IntegerMappingTransformation": "integer mapping transformations",
    "EnumerationMappingTransformation": "enumeration mapping transformations",
    "Dimensions": "array connectors (SSP 2.0 dimensions)",
    "Clock": "clocked connectors",
}


_READ_ANNOTATIONS = {FMIONNX_ANNOTATION, OMS_ANNOTATION}


def report_unread(tree: Any, file: Path, bag: DiagnosticBag) -> None:
    """W070 for harmless elements fmionnx skips, E071 for those that change the result."""
    warned: set[str] = set()
    layout: list[Any] = []
    for node in tree.getroot().iter():
        if not isinstance(node.tag, str):
            continue
        parent = node.getparent()
        if parent is not None and parent.tag == tag("ssc", "Annotation"):
            continue
        if any(
            a.tag == tag("ssc", "Annotation")
            or etree_local(a.tag) in _UNSUPPORTED
            or etree_local(a.tag) in _LAYOUT  # a diagram's notes and shapes: layout too
            for a in node.iterancestors()
        ):
            continue
        local = etree_local(node.tag)
        kind = node.get("type") if node.tag == tag("ssc", "Annotation") else None
        if kind is not None and kind not in _READ_ANNOTATIONS and kind not in warned:
            warned.add(kind)
            bag.emit(
                codes.SSP_IGNORED,
                f"annotations of type `{kind}` are ignored",
                Span(file, node.sourceline),
            )
        elif local in _UNSUPPORTED:
            bag.emit(
                codes.SSP_UNSUPPORTED,
                f"{_UNSUPPORTED[local]} are not supported yet (`{short(node.tag)}`)",
                Span(file, node.sourceline),
                hint="see docs/ssp.md for what fmionnx reads",
            )
        elif local in _LAYOUT:
            layout.append(node)
        elif local in _HARMLESS and local not in warned:
            warned.add(local)
            bag.emit(
                codes.SSP_IGNORED,
                f"`{short(node.tag)}` is ignored (layout or documentation only)",
                Span(file, node.sourceline),
            )
        elif local not in _UNDERSTOOD and local not in _HARMLESS:
            bag.emit(
                codes.SSP_IGNORED,
                f"`{short(node.tag)}` is not read by fmionnx and is ignored",
                Span(file, node.sourceline),
            )
    if layout:
        kinds = ", ".join(sorted({f"`{etree_local(n.tag)}`" for n in layout}))
        bag.emit(
            codes.SSP_LAYOUT,
            f"the diagram layout ({len(layout)} elements: {kinds}) is not used: it does not "
            "change what the system computes",
            Span(file, layout[0].sourceline),
        )


def etree_local(name: str) -> str:
    """Local part of a Clark-notation tag."""
    return name.rsplit("}", 1)[-1]
