"""The SSD's connections as one graph of pins, across every system boundary.

A pin is ``(element path, connector name)``: ``(("ctrl", "gain2"), "u")`` is a component
connector, ``(("ctrl",), "in")`` a connector of the system ``ctrl`` and ``((), "in")`` one of
the root system. Each ``ssd:Connection`` becomes an edge carrying the ``factor``/``offset``
of its unit conversion and linear transformation (unit conversion first, as the standard
says). A system connector is a junction: :meth:`SystemGraph.reach` walks from any pin through
system connectors to the component connectors at the ends, composing the edges'
transformations, which is what flattening connections and propagating bound values to
"top-level parameters" both need. The problems only the whole graph shows (a system connector
driven twice, a cycle through system connectors) are reported here as E073.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span
from fmionnx.spec.ssp_tree import Connection, Connector, Document, Element, Unit

Pin = tuple[tuple[str, ...], str]


@dataclass(frozen=True, slots=True)
class Edge:
    """One ``ssd:Connection`` between two pins, with its composed transformation."""

    start: Pin
    end: Pin
    factor: float
    offset: float
    line: int
    units_settled: bool = False


@dataclass(frozen=True, slots=True)
class Reached:
    """A component connector at the end of a chain, and the chain's composed transformation.

    ``settled`` says that a unit conversion was already folded into ``factor``/``offset`` on
    the way, so the compiler must not convert the ports' units a second time; ``line`` is the
    line of the chain's last connection, the one naming the component connector.
    """

    pin: Pin
    factor: float
    offset: float
    settled: bool
    line: int

    @property
    def identity(self) -> bool:
        """No transformation at all along the chain."""
        return self.factor == 1.0 and self.offset == 0.0


def pin_text(pin: Pin) -> str:
    """``sub.conn`` for a connector of a nested system, ``conn`` for one of the root."""
    return ".".join((*pin[0], pin[1])) if pin[0] else pin[1]


def system_text(path: tuple[str, ...], root_name: str) -> str:
    """How a diagnostic names a system: ``ctrl.inner``, or ``root system `name```."""
    return f"system `{'.'.join(path)}`" if path else f"the root system `{root_name}`"


def _walk(
    element: Element, path: tuple[str, ...], out: list[tuple[tuple[str, ...], Element]]
) -> None:
    out.append((path, element))
    for child in element.children:
        _walk(child, (*path, child.name), out)


class SystemGraph:
    """Elements, connectors and connections of a whole SSD, systems flattened into pins."""

    def __init__(self, document: Document, ssd: Path, bag: DiagnosticBag) -> None:
        self.document = document
        self.ssd = ssd
        self.bag = bag
        self.elements: list[tuple[tuple[str, ...], Element]] = []
        _walk(document.root, (), self.elements)
        self.paths = dict(self.elements)
        self.components = {p: e for p, e in self.elements if not e.is_system}
        self.connectors: dict[Pin, Connector] = {
            (p, c.name): c for p, e in self.elements for c in e.connectors
        }
        self.edges: dict[Pin, list[Edge]] = defaultdict(list)
        self.into: dict[Pin, list[Edge]] = defaultdict(list)
        #: Every edge in document order (systems outside in, connections as written).
        self.ordered: list[Edge] = []
        for path, element in self.elements:
            if element.is_system:
                for connection in element.connections:
                    edge = self._edge(path, connection)
                    if edge is not None:
                        self.edges[edge.start].append(edge)
                        self.into[edge.end].append(edge)
                        self.ordered.append(edge)
        #: An E073 was found: the graph is not walked (see :meth:`_walk`).
        self.broken = False
        self._check_drivers()
        self._check_cycles()

    @property
    def root_name(self) -> str:
        return self.document.root.name

    def span(self, line: int) -> Span:
        return Span(self.ssd, line)

    def is_system_pin(self, pin: Pin) -> bool:
        return pin[0] not in self.components

    # --- building
    def _pin(self, path: tuple[str, ...], element: str | None, connector: str) -> Pin:
        # OMSimulator writes `startElement=""` for the system's own connectors.
        return ((*path, element) if element else path, connector)

    def _edge(self, path: tuple[str, ...], connection: Connection) -> Edge | None:
        start = self._pin(path, connection.start_element, connection.start_connector)
        end = self._pin(path, connection.end_element, connection.end_connector)
        for pin, role in ((start, "start"), (end, "end")):
            if pin[0] not in self.paths:
                self.bag.emit(
                    codes.SSP_REFERENCE,
                    f"connection {role} element `{pin[0][-1]}` does not exist in system "
                    f"`{'.'.join(path) or self.root_name}`",
                    self.span(connection.line),
                )
                return None
            if pin[0] not in self.components and pin not in self.connectors:
                self.bag.emit(
                    codes.SSP_REFERENCE,
                    f"system `{'.'.join(pin[0]) or self.root_name}` has no connector `{pin[1]}`",
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
        return Edge(start, end, factor, offset, connection.line, settled)

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
                codes.SSP_IGNORED,
                f"unit `{missing}` is not declared in `ssd:Units`; the units of the ports "
                f"themselves decide the conversion from `{first.unit}` to `{second.unit}`",
                self.span(connection.line),
            )
            return 1.0, 0.0
        if source.exponents != target.exponents:
            self.bag.emit(
                codes.UNIT,
                f"connector units `{first.unit}` and `{second.unit}` measure different quantities",
                self.span(connection.line),
                hint="connect compatible signals, or set suppressUnitConversion with a "
                "LinearTransformation",
            )
            return 1.0, 0.0
        return _conversion(source, target)

    # --- whole-graph checks
    def _check_drivers(self) -> None:
        """A system connector is one signal: two connections into it cannot both drive it."""
        for pin, edges in self.into.items():
            if not self.is_system_pin(pin) or len(edges) < 2:
                continue
            first, second = edges[0], edges[1]
            self.broken = True
            self.bag.emit(
                codes.SSP_JUNCTION,
                f"connector `{pin[1]}` of {system_text(pin[0], self.root_name)} is driven by "
                f"{len(edges)} connections; a system connector passes on one signal",
                self.span(second.line),
                notes=[Note("first connection into it", self.span(first.line))],
                hint="connect one source to it and fan out from it to as many inputs as needed",
            )

    def _check_cycles(self) -> None:
        """Connections that lead from a system connector back to itself pass on nothing.

        Iterative depth-first search over the system connectors (a hostile SSD may chain
        thousands of them): a connector met again while still on the path closes a cycle.
        """
        state: dict[Pin, bool] = {}  # False: on the current path, True: finished
        for start in [p for p in self.edges if self.is_system_pin(p)]:
            if start in state:
                continue
            state[start] = False
            path = [start]
            stack = [iter(self._system_ends(start))]
            while stack:
                following = next(stack[-1], None)
                if following is None:
                    state[path.pop()] = True
                    stack.pop()
                elif following not in state:
                    state[following] = False
                    path.append(following)
                    stack.append(iter(self._system_ends(following)))
                elif state[following] is False:
                    self._report_cycle(path[path.index(following) :], following)

    def _system_ends(self, pin: Pin) -> list[Pin]:
        return [e.end for e in self.edges.get(pin, []) if self.is_system_pin(e.end)]

    def _report_cycle(self, loop: list[Pin], back: Pin) -> None:
        self.broken = True
        shown = [pin_text(p) for p in (*loop, back)]
        if len(shown) > 8:  # a hostile file's cycle of thousands: its ends say where it is
            shown = [*shown[:4], f"... ({len(shown) - 6} more)", *shown[-2:]]
        names = " -> ".join(shown)
        closing = next(e for e in self.edges[loop[-1]] if e.end == back)
        self.bag.emit(
            codes.SSP_JUNCTION,
            f"connections through system connectors form a cycle: {names}",
            self.span(closing.line),
            hint="a system connector is a junction between component connectors; remove one "
            "of these connections",
        )

    # --- walking
    def reach(self, edge: Edge) -> list[Reached]:
        """Component connectors that ``edge`` leads to, through any system connectors."""
        return self._walk([edge], set())

    def reach_from(self, pin: Pin) -> list[Reached]:
        """Component connectors that the (system) connector ``pin`` leads to."""
        return self._walk(list(self.edges.get(pin, [])), {pin})

    def _walk(self, first: list[Edge], seen: set[Pin]) -> list[Reached]:
        """Follow edges on through system connectors, each visited once per walk.

        After an E073 (a connector driven twice, a cycle) nothing is walked: the file is
        refused anyway, and a hostile graph of diamonds must not cost exponential time.
        """
        found: list[Reached] = []
        if self.broken:
            return found
        stack = [(edge, 1.0, 0.0, False) for edge in reversed(first)]
        while stack:
            edge, factor, offset, settled = stack.pop()
            factor, offset = edge.factor * factor, edge.factor * offset + edge.offset
            settled = settled or edge.units_settled
            target = edge.end
            if not self.is_system_pin(target):
                found.append(Reached(target, factor, offset, settled, edge.line))
                continue
            if target in seen:
                continue
            seen.add(target)
            following = self.edges.get(target, [])
            stack.extend((e, factor, offset, settled) for e in reversed(following))
        return found

    def passes(self, edge: Edge) -> set[Pin]:
        """System connectors a chain starting with ``edge`` passes through."""
        passed: set[Pin] = set()
        stack = [edge.end]
        while stack:
            pin = stack.pop()
            if not self.is_system_pin(pin) or pin in passed:
                continue
            passed.add(pin)
            stack.extend(e.end for e in self.edges.get(pin, []))
        return passed


def _conversion(source: Unit, target: Unit) -> tuple[float, float]:
    # value_SI = f * x + o on both sides, so x_target = (f_s * x + o_s - o_t) / f_t.
    return source.factor / target.factor, (source.offset - target.offset) / target.factor
