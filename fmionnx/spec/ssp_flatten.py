"""Flatten an SSD's system hierarchy into components, connections and parameter values.

Components get dotted names from the root system down (``sub.inner.gain``; the root system's
own name is not part of them). A system connector is a junction (:mod:`fmionnx.spec.ssp_graph`):
a connection through system connectors is followed from the component connector that drives
it, across every system boundary, to each component connector it reaches; the linear
transformations and unit conversions met on the way are composed into one ``factor``/
``offset``. A chain whose units were settled here (both connectors of an edge name different
units declared in ``ssd:Units``, or ``suppressUnitConversion``) is marked
``convert_units=False``, so that the compiler does not convert the ports' units a second
time; on any other chain the compiler converts between the units of the ports themselves
(SSP: a connector without a unit has its component variable's unit).

Values bound to components and to system connectors are resolved by
:mod:`fmionnx.spec.ssp_bind`. What is left over are *open* system connectors: an ``input`` or
``parameter`` connector that nothing drives and no binding sets. Each becomes a named system
input (``conn`` on the root system, ``sub.conn`` on a nested one) whose value the command line
can set (``--param conn=1``) and that reaches the component connectors at the ends of its
chains, transformations included. A root connector bound to a value and connected to nothing
becomes a system input holding that value (no targets), as OMSimulator keeps it; so does a
bound root connector that our annotation names (``bound_inputs``: an exported ``inputs:`` entry
with a value and ports), with its targets. System inputs are listed in the order their
connectors are declared.
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span
from fmionnx.spec.runspec import ENDPOINT_RE
from fmionnx.spec.ssp_bind import bind_parameters
from fmionnx.spec.ssp_graph import Pin, Reached, SystemGraph, pin_text, system_text
from fmionnx.spec.ssp_names import fmi_to_port_label
from fmionnx.spec.ssp_params import BoundValue
from fmionnx.spec.ssp_tree import Document, Element

FMU_MIME = "application/x-fmu-sharedlibrary"
#: Kinds of system connectors that, left open, can be set from outside the system.
SETTABLE_KINDS = ("input", "parameter")


@dataclass(frozen=True, slots=True)
class FlatConnection:
    """A component-to-component connection: dotted endpoints and the composed transform."""

    src: str
    dst: str
    factor: float
    offset: float
    line: int
    convert_units: bool = True


@dataclass(frozen=True, slots=True)
class FlatTarget:
    """A component connector an open system input reaches, and the chain's transformation."""

    endpoint: str
    factor: float
    offset: float
    line: int


@dataclass(frozen=True, slots=True)
class FlatInput:
    """An open system connector: its name, where it is declared, what it reaches."""

    name: str
    line: int
    targets: tuple[FlatTarget, ...]
    #: The value bound to it (a root connector bound to a value, connected to nothing).
    value: BoundValue | None = None


@dataclass
class FlatSystem:
    """What the front end needs to build a SystemSpec."""

    components: dict[str, Element] = field(default_factory=dict)
    connections: list[FlatConnection] = field(default_factory=list)
    parameters: dict[str, dict[str, BoundValue]] = field(default_factory=lambda: defaultdict(dict))
    inputs: dict[str, FlatInput] = field(default_factory=dict)
    #: Every system connector (``conn``, ``sub.conn``) -> its rank in the document: system
    #: inputs are listed in this order.
    declared: dict[str, int] = field(default_factory=dict)


def endpoint_text(graph: SystemGraph, pin: Pin, line: int) -> str | None:
    """``comp.port[i]`` of a component pin, FMI 2 element names made 0-based (None: E072)."""
    label = pin[1]
    if graph.components[pin[0]].type == FMU_MIME:
        shifted = fmi_to_port_label(label)
        if shifted is None:
            graph.bag.emit(
                codes.SSP_REFERENCE,
                f"connector `{label}` of FMU component `{'.'.join(pin[0])}`: FMI element "
                "names count from 1",
                graph.span(line),
            )
            return None
        label = shifted
    text = ".".join(pin[0]) + "." + label
    if ENDPOINT_RE.match(text) is None and '"' not in label:  # `input.1`, `front left`
        index = _TRAILING_INDEX.search(label)
        name, tail = (label, "") if index is None else (label[: index.start()], index.group())
        text = ".".join(pin[0]) + f'."{name}"{tail}'  # the port named whole, in quotes
    return text


#: The element index at the end of a connector's name (``12[1]``: ``[1]``).
_TRAILING_INDEX = re.compile(r"\[\d+(?:,\d+)*\]$")


def _flatten_connections(graph: SystemGraph, flat: FlatSystem) -> set[Pin]:
    """Component-to-component connections; returns the system connectors they pass."""
    driven: set[Pin] = set()
    for edge in graph.ordered:
        if graph.is_system_pin(edge.start):
            continue
        driven |= graph.passes(edge)
        for reached in graph.reach(edge):
            src = endpoint_text(graph, edge.start, edge.line)
            dst = endpoint_text(graph, reached.pin, reached.line)
            if src is None or dst is None:
                continue
            flat.connections.append(
                FlatConnection(
                    src,
                    dst,
                    reached.factor,
                    reached.offset,
                    reached.line,
                    convert_units=not reached.settled,
                )
            )
    return driven


def _open_connectors(graph: SystemGraph, covered: set[Pin], flat: FlatSystem) -> None:
    """Open settable system connectors become system inputs; other loose ends a W070."""
    heads = [pin for pin in graph.edges if graph.is_system_pin(pin) and pin not in graph.into]
    for pin in heads:
        if pin in covered or graph.broken:
            continue
        connector = graph.connectors[pin]
        reached = graph.reach_from(pin)
        if connector.kind in SETTABLE_KINDS and reached:
            targets = [_target(graph, r) for r in reached]
            name = pin_text(pin)
            flat.inputs[name] = FlatInput(
                name, connector.line, tuple(t for t in targets if t is not None)
            )
            continue
        first = graph.edges[pin][0]
        where = f"connector `{pin[1]}` of {system_text(pin[0], graph.root_name)}"
        if not reached:
            message = f"{where} leads to no component connector; it is not used"
        else:
            message = (
                f"{where} is driven by no component; the inputs it feeds keep their start values"
            )
        graph.bag.emit(codes.SSP_IGNORED, message, graph.span(first.line))


def _target(graph: SystemGraph, reached: Reached) -> FlatTarget | None:
    endpoint = endpoint_text(graph, reached.pin, reached.line)
    if endpoint is None:
        return None
    return FlatTarget(endpoint, reached.factor, reached.offset, reached.line)


def flatten(
    document: Document,
    ssd: Path,
    root: Path | None,
    bag: DiagnosticBag,
    bound_inputs: frozenset[str] = frozenset(),
) -> FlatSystem:
    """Flatten ``document``; problems go into ``bag``.

    ``bound_inputs`` names root connectors that stay system inputs with the value bound to
    them (our annotation says so): see :func:`fmionnx.spec.ssp_bind.bind_parameters`.
    """
    if not _unique_names(document, ssd, bag):
        return FlatSystem()  # the elements cannot be told apart: nothing to flatten
    graph = SystemGraph(document, ssd, bag)
    flat = FlatSystem()
    for path, element in graph.components.items():
        flat.components[".".join(path)] = element
    flat.declared = {
        pin_text(pin): rank
        for rank, pin in enumerate(pin for pin in graph.connectors if graph.is_system_pin(pin))
    }
    driven = _flatten_connections(graph, flat)
    kept: dict[Pin, BoundValue] = {}
    bound = bind_parameters(graph, root, flat.parameters, kept, bound_inputs)
    for pin, value in kept.items():
        targets = (_target(graph, r) for r in graph.reach_from(pin))
        flat.inputs[pin_text(pin)] = FlatInput(
            pin_text(pin),
            graph.connectors[pin].line,
            tuple(t for t in targets if t is not None),
            value,
        )
    _open_connectors(graph, driven | bound, flat)
    _check_duplicates(flat, ssd, bag)
    return flat


def _unique_names(document: Document, ssd: Path, bag: DiagnosticBag) -> bool:
    """Each element name once in its system, each flattened component name once (E007).

    SSP requires the names of a system's elements to be unique; a second element of the same
    name would replace the first in the flattened system, and one component would silently
    be lost. Flattening can also make two names equal that differ in the file: a root
    component named ``s.g`` and the component ``g`` of the nested system ``s``.
    """
    unique = True
    components: list[tuple[str, tuple[str, ...], Element]] = []
    pending: list[tuple[tuple[str, ...], Element]] = [((), document.root)]
    while pending:  # iterative: a hostile file may nest systems deeply
        path, system = pending.pop()
        seen: dict[str, Element] = {}
        for child in system.children:
            first = seen.setdefault(child.name, child)
            if first is not child:
                unique = False
                bag.emit(
                    codes.DUPLICATE_KEY,
                    f"{system_text(path, document.root.name)} has two elements named "
                    f"`{child.name}`",
                    Span(ssd, child.line),
                    notes=[
                        Note(f"the first `{child.name}` is declared here", Span(ssd, first.line))
                    ],
                    hint="element names must be unique within their system; rename one",
                )
            elif child.is_system:
                pending.append(((*path, child.name), child))
            else:
                components.append((".".join((*path, child.name)), path, child))
    named: dict[str, tuple[tuple[str, ...], Element]] = {}
    for name, path, element in sorted(components, key=lambda c: c[2].line):
        other = named.setdefault(name, (path, element))
        if other[1] is not element:
            unique = False
            bag.emit(
                codes.DUPLICATE_KEY,
                f"component `{element.name}` of {system_text(path, document.root.name)} is "
                f"named `{name}` once nested systems are flattened, like component "
                f"`{other[1].name}` of {system_text(other[0], document.root.name)}",
                Span(ssd, element.line),
                notes=[Note(f"the other `{name}` is declared here", Span(ssd, other[1].line))],
                hint="rename one: fmionnx names a nested component `system.component`",
            )
    return unique


def _check_duplicates(flat: FlatSystem, ssd: Path, bag: DiagnosticBag) -> None:
    """Two inputs fed by the same connection chain twice are reported by the compiler."""
    seen: dict[tuple[str, str], FlatConnection] = {}
    for connection in flat.connections:
        key = (connection.src, connection.dst)
        if key in seen:
            bag.emit(
                codes.SSP_IGNORED,
                f"`{connection.src}` reaches `{connection.dst}` along two paths; one is kept",
                Span(ssd, connection.line),
                notes=[Note("first path ends here", Span(ssd, seen[key].line))],
            )
        seen[key] = connection
    unique = {(c.src, c.dst): c for c in flat.connections}
    flat.connections = list(unique.values())
