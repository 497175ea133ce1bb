"""Flatten an SSD's system hierarchy into components, connections and parameter values.

Components get dotted names from the root system down (``sub.inner.gain``; the root system's
own name is not part of them). A connection through system connectors is followed from the
component connector that drives it, across every system boundary, to each component connector
it reaches; the linear transformations and unit conversions met on the way are composed into
one ``factor``/``offset``. A chain whose units were settled here (both connectors of an edge
name different units declared in ``ssd:Units``, or ``suppressUnitConversion``) is marked
``convert_units=False``, so that the compiler does not convert the ports' units a second
time; on any other chain the compiler converts between the units of the ports themselves
(SSP: a connector without a unit has its component variable's unit). Parameter bindings on
systems are matched to the component whose dotted name is the longest prefix of the parameter
name, or followed through the system's ``parameter`` connectors. Outer bindings override inner
ones, later bindings earlier ones.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core.diagnostics import DiagnosticBag, Note, Span
from fmionnx.spec.ssp_names import fmi_to_port_label
from fmionnx.spec.ssp_params import BoundValue, binding_values
from fmionnx.spec.ssp_tree import Connection, Connector, Document, Element, Unit

Pin = tuple[tuple[str, ...], str]
FMU_MIME = "application/x-fmu-sharedlibrary"


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
class _Edge:
    start: Pin
    end: Pin
    factor: float
    offset: float
    line: int
    units_settled: bool = False


@dataclass
class FlatSystem:
    """What the front end needs to build a SystemSpec."""

    components: dict[str, Element] = field(default_factory=dict)
    connections: list[FlatConnection] = field(default_factory=list)
    parameters: dict[str, dict[str, BoundValue]] = field(default_factory=lambda: defaultdict(dict))


def _walk(
    element: Element, path: tuple[str, ...], out: list[tuple[tuple[str, ...], Element]]
) -> None:
    out.append((path, element))
    for child in element.children:
        _walk(child, (*path, child.name), out)


class _Flattener:
    def __init__(
        self, document: Document, ssd: Path, root: Path | None, bag: DiagnosticBag
    ) -> None:
        self.document = document
        self.ssd = ssd
        self.root = root
        self.bag = bag
        self.elements: list[tuple[tuple[str, ...], Element]] = []
        _walk(document.root, (), self.elements)
        self.components = {p: e for p, e in self.elements if not e.is_system}
        self.connectors: dict[Pin, Connector] = {
            (p, c.name): c for p, e in self.elements for c in e.connectors
        }
        self.edges: dict[Pin, list[_Edge]] = defaultdict(list)

    def span(self, line: int) -> Span:
        return Span(self.ssd, line)

    # --- connections
    def collect_edges(self) -> list[_Edge]:
        ordered: list[_Edge] = []
        for path, element in self.elements:
            if not element.is_system:
                continue
            for connection in element.connections:
                edge = self._edge(path, connection)
                if edge is not None:
                    self.edges[edge.start].append(edge)
                    ordered.append(edge)
        return ordered

    def _pin(self, path: tuple[str, ...], element: str | None, connector: str) -> Pin:
        return ((*path, element) if element else path, connector)

    def _edge(self, path: tuple[str, ...], connection: Connection) -> _Edge | None:
        start = self._pin(path, connection.start_element, connection.start_connector)
        end = self._pin(path, connection.end_element, connection.end_connector)
        known = {p for p, _ in self.elements}
        for pin, role in ((start, "start"), (end, "end")):
            if pin[0] not in known:
                self.bag.emit(
                    "E072",
                    f"connection {role} element `{pin[0][-1]}` does not exist in system "
                    f"`{'.'.join(path) or self.document.root.name}`",
                    self.span(connection.line),
                )
                return None
            if pin[0] not in self.components and pin not in self.connectors:
                self.bag.emit(
                    "E072",
                    f"system `{'.'.join(pin[0]) or self.document.root.name}` has no connector "
                    f"`{pin[1]}`",
                    self.span(connection.line),
                )
                return None
        factor, offset = self._unit_conversion(start, end, connection)
        if connection.transformation is not None:
            t = connection.transformation
            factor, offset = t.factor * factor, t.factor * offset + t.offset
        first, second = self.connectors.get(start), self.connectors.get(end)
        declared = [c is not None and c.unit in self.document.units for c in (first, second)]
        differ = first is not None and second is not None and first.unit != second.unit
        settled = connection.suppress_unit_conversion or (all(declared) and differ)
        return _Edge(start, end, factor, offset, connection.line, settled)

    def _unit_conversion(self, start: Pin, end: Pin, connection: Connection) -> tuple[float, float]:
        """``(a, b)`` with ``target = a * source + b`` between the connectors' units."""
        if connection.suppress_unit_conversion:
            return 1.0, 0.0
        first, second = self.connectors.get(start), self.connectors.get(end)
        if first is None or second is None or not first.unit or not second.unit:
            return 1.0, 0.0
        if first.unit == second.unit:
            return 1.0, 0.0
        units = self.document.units
        source, target = units.get(first.unit), units.get(second.unit)
        if source is None or target is None:
            missing = first.unit if source is None else second.unit
            self.bag.emit(
                "W070",
                f"unit `{missing}` is not declared in `ssd:Units`; the units of the ports "
                f"themselves decide the conversion from `{first.unit}` to `{second.unit}`",
                self.span(connection.line),
            )
            return 1.0, 0.0
        if source.exponents != target.exponents:
            self.bag.emit(
                "E033",
                f"connector units `{first.unit}` and `{second.unit}` measure different quantities",
                self.span(connection.line),
                hint="connect compatible signals, or set suppressUnitConversion with a "
                "LinearTransformation",
            )
            return 1.0, 0.0
        return _conversion(source, target)

    def flatten_connections(self, flat: FlatSystem) -> None:
        ordered = self.collect_edges()
        reached: set[Pin] = set()
        for edge in ordered:
            if edge.start[0] not in self.components:
                continue
            self._follow(edge.start, edge, (1.0, 0.0, False), (), flat, reached)
        for edge in ordered:
            dangling = edge.start[0] not in self.components and edge.start not in reached
            if dangling and not self.edges_into(edge.start):
                where = ".".join(edge.start[0]) or "the root system"
                self.bag.emit(
                    "W070",
                    f"connector `{edge.start[1]}` of {where} is driven by no component; "
                    "the inputs it feeds keep their start values",
                    self.span(edge.line),
                )

    def edges_into(self, pin: Pin) -> bool:
        return any(e.end == pin for edges in self.edges.values() for e in edges)

    def _follow(
        self,
        source: Pin,
        edge: _Edge,
        so_far: tuple[float, float, bool],
        seen: tuple[Pin, ...],
        flat: FlatSystem,
        reached: set[Pin],
    ) -> None:
        """Follow ``edge`` on; ``so_far`` is the chain's factor, offset and whether its units
        were settled on the way."""
        factor, offset, settled = so_far
        factor, offset = edge.factor * factor, edge.factor * offset + edge.offset
        settled = settled or edge.units_settled
        target = edge.end
        if target in seen:
            return
        if target[0] in self.components:
            flat.connections.append(
                FlatConnection(
                    self._text(source, edge.line),
                    self._text(target, edge.line),
                    factor,
                    offset,
                    edge.line,
                    convert_units=not settled,
                )
            )
            return
        reached.add(target)
        for following in self.edges.get(target, []):
            self._follow(
                source, following, (factor, offset, settled), (*seen, target), flat, reached
            )

    def _text(self, pin: Pin, line: int) -> str:
        """``comp.port[i]`` of a component pin, FMI 2 element names made 0-based."""
        label = pin[1]
        if self.components[pin[0]].type == FMU_MIME:
            shifted = fmi_to_port_label(label)
            if shifted is None:
                self.bag.emit(
                    "E072",
                    f"connector `{label}` of FMU component `{'.'.join(pin[0])}`: FMI element "
                    "names count from 1",
                    self.span(line),
                )
            else:
                label = shifted
        return ".".join(pin[0]) + "." + label

    # --- parameters
    def bind_parameters(self, flat: FlatSystem) -> None:
        # Innermost first, so that outer bindings (processed later) override them.
        for path, element in sorted(self.elements, key=lambda item: -len(item[0])):
            for binding in element.bindings:
                for value in binding_values(binding, self.ssd, self.root, self.bag):
                    self._assign(path, element, value, flat)

    def _assign(
        self, path: tuple[str, ...], element: Element, value: BoundValue, flat: FlatSystem
    ) -> None:
        if not element.is_system:
            flat.parameters[".".join(path)][value.name] = value
            return
        for pin in self._parameter_targets(path, value.name):
            flat.parameters[".".join(pin[0])][pin[1]] = BoundValue(pin[1], value.value, value.span)
            return
        best: tuple[str, ...] | None = None
        for component in self.components:
            if component[: len(path)] != path or len(component) == len(path):
                continue
            prefix = ".".join(component[len(path) :]) + "."
            if value.name.startswith(prefix) and (best is None or len(component) > len(best)):
                best = component
        if best is None:
            self.bag.emit(
                "E072",
                f"parameter `{value.name}` bound on system `{element.name}` names no component "
                "inside it",
                value.span,
                hint="prefix the parameter with the component name (`gain.k`) or give the "
                "binding a `prefix`",
            )
            return
        name = value.name[len(".".join(best[len(path) :])) + 1 :]
        flat.parameters[".".join(best)][name] = BoundValue(name, value.value, value.span)

    def _parameter_targets(self, path: tuple[str, ...], name: str) -> list[Pin]:
        """Component pins reached from the system's parameter connector ``name``."""
        start = (path, name)
        if start not in self.connectors:
            return []
        found: list[Pin] = []
        stack, seen = [start], {start}
        while stack:
            pin = stack.pop()
            for edge in self.edges.get(pin, []):
                if edge.end in seen:
                    continue
                seen.add(edge.end)
                if edge.end[0] in self.components:
                    found.append(edge.end)
                else:
                    stack.append(edge.end)
        return found


def _conversion(source: Unit, target: Unit) -> tuple[float, float]:
    # value_SI = f * x + o on both sides, so x_target = (f_s * x + o_s - o_t) / f_t.
    return source.factor / target.factor, (source.offset - target.offset) / target.factor


def flatten(document: Document, ssd: Path, root: Path | None, bag: DiagnosticBag) -> FlatSystem:
    """Flatten ``document``; problems go into ``bag``."""
    flattener = _Flattener(document, ssd, root, bag)
    flat = FlatSystem()
    for path, element in flattener.components.items():
        flat.components[".".join(path)] = element
    flattener.flatten_connections(flat)
    flattener.bind_parameters(flat)
    _check_duplicates(flat, ssd, bag)
    return flat


def _check_duplicates(flat: FlatSystem, ssd: Path, bag: DiagnosticBag) -> None:
    """Two inputs fed by the same connection chain twice are reported by the compiler."""
    seen: dict[tuple[str, str], FlatConnection] = {}
    for connection in flat.connections:
        key = (connection.src, connection.dst)
        if key in seen:
            bag.emit(
                "W070",
                f"`{connection.src}` reaches `{connection.dst}` along two paths; one is kept",
                Span(ssd, connection.line),
                notes=[Note("first path ends here", Span(ssd, seen[key].line))],
            )
        seen[key] = connection
    unique = {(c.src, c.dst): c for c in flat.connections}
    flat.connections = list(unique.values())
