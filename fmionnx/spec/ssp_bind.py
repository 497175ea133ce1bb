"""Parameter values of SSP bindings, resolved to the component connectors they set.

A binding on a component sets that component's parameters by name. A binding on a system
names, for each value, one of:

* a connector of that system (``k_cref``), or of a system nested in it (``sub.k_cref``): the
  value flows along the connector's connections, through further system connectors, to every
  component connector they reach, each linear transformation and unit conversion on the way
  applied to it. This is how OMSimulator and other tools give a system "top-level
  parameters" and top-level input values, often renamed by an ``.ssm`` mapping;
* a parameter of a component inside it, as ``comp.k`` or ``sub.comp.k`` (the component with
  the longest dotted name that prefixes the value's name).

Precedence (SSP 2.0, section 5.2.3 "ParameterBindings" and 5.3.2 "Connections"):

1. A component connector that a connection from a bound system connector reaches takes the
   value that flows along the connection: the connection is its one source of data ("Allowed
   Connections": no more than one inbound connection into a parameter or input), so a direct
   binding of the same connector (``addP.k1 = 10`` next to ``k_cref = 30`` wired to
   ``addP.k1``) does not override it, whatever the order or level of the two bindings.
2. Otherwise, bindings at a higher hierarchy level take precedence over lower levels (system
   over sub-system over component): bindings are applied innermost element first.
3. At the same level, a later binding overrides an earlier one, and within one parameter set
   a later entry an earlier one.

SSP gives a system connector no start value of its own (``ssc:Real`` has a ``unit`` and
nothing else, in 1.0 and 2.0): its value comes from a binding or from a connection. A bound
connector of the root system that leads to no component connector is kept with its value as
a system input (OMSimulator keeps it too), so that ``run.json`` shows it.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.specbase import ScalarLiteral
from fmionnx.core.types import is_number
from fmionnx.spec.ssp_graph import Pin, Reached, SystemGraph, system_text
from fmionnx.spec.ssp_params import BoundValue, binding_values
from fmionnx.spec.ssp_tree import Element

Parameters = dict[str, dict[str, BoundValue]]


def bind_parameters(
    graph: SystemGraph,
    root: Path | None,
    parameters: Parameters,
    kept: dict[Pin, BoundValue] | None = None,
    inputs: frozenset[str] = frozenset(),
) -> set[Pin]:
    """Fill ``parameters`` (component -> name -> value); return the system connectors set.

    ``kept`` receives the values bound to root-system connectors that stay system inputs
    with that value: those that lead to no component connector, and those named in
    ``inputs`` (our annotation's ``bound_inputs``: an exported ``inputs:`` entry with a
    value and ports, whose value the compiler sets on its ports as for a system file).
    """
    bound: set[Pin] = set()
    # Innermost first, so that outer bindings (applied later) override them.
    for path, element in sorted(graph.elements, key=lambda item: -len(item[0])):
        for binding in element.bindings:
            for value in binding_values(binding, graph.ssd, root, graph.bag):
                if not element.is_system:
                    _set(parameters, ".".join(path), value)
                    continue
                pin = _assign(graph, path, element, value, parameters, kept, inputs)
                if pin is not None:
                    bound |= _downstream(graph, pin)
    return bound


def _set(parameters: Parameters, component: str, value: BoundValue) -> None:
    """Set ``value`` unless a value that came along a connection holds the connector."""
    held = parameters[component].get(value.name)
    if held is not None and held.via_connection and not value.via_connection:
        return
    parameters[component][value.name] = value


def _assign(
    graph: SystemGraph,
    path: tuple[str, ...],
    element: Element,
    value: BoundValue,
    parameters: Parameters,
    kept: dict[Pin, BoundValue] | None = None,
    inputs: frozenset[str] = frozenset(),
) -> Pin | None:
    """Set ``value`` bound on the system at ``path``; the system connector it set, if any."""
    target = _resolve(graph, path, value.name)
    if target is None:
        graph.bag.emit(
            codes.SSP_REFERENCE,
            f"parameter `{value.name}` bound on system `{element.name}` names no component "
            "or system connector inside it",
            value.span,
            hint="name a connector of the system (`k`), of a nested system (`sub.k`), or a "
            "component's parameter (`gain.k`); or give the binding a `prefix`",
        )
        return None
    pin, is_connector = target
    if not is_connector:
        _set(parameters, ".".join(pin[0]), replace(value, name=pin[1]))
        return None
    value = _in_connector_unit(graph, pin, value)
    if kept is not None and _stays_input(graph, pin, value, inputs):
        kept[pin] = value  # the compiler sets the ports it reaches, as for a system file
        return pin
    reached = graph.reach_from(pin)
    if not reached and not pin[0] and kept is not None and not graph.broken:
        kept[pin] = value  # a top-level connector bound to a value: a system input
    elif not reached and not graph.broken:
        graph.bag.emit(
            codes.SSP_IGNORED,
            f"`{value.name}` sets connector `{pin[1]}` of "
            f"{system_text(pin[0], graph.root_name)}, which leads to no component connector; "
            "the value is not used",
            value.span,
        )
    for end in reached:
        result = _transformed(graph, value, end)
        if result is not None:
            component = ".".join(end.pin[0])
            carried = replace(value, name=end.pin[1], value=result, via_connection=True)
            _set(parameters, component, carried)
    return pin


def _stays_input(graph: SystemGraph, pin: Pin, value: BoundValue, inputs: frozenset[str]) -> bool:
    """Whether a value bound to ``pin`` is the value of a system input named in ``inputs``.

    Only a root connector that nothing drives, whose value needs no unit conversion by the
    compiler (a system input's value has no unit): otherwise the value flows on as any other.
    """
    return (
        not pin[0]
        and pin[1] in inputs
        and value.unit is None
        and not graph.into.get(pin)
        and not graph.broken
    )


def _in_connector_unit(graph: SystemGraph, pin: Pin, value: BoundValue) -> BoundValue:
    """``value`` in the unit of the system connector it is bound to, when both units are known.

    A value written in another unit (``20 N.cm`` for a connector in ``Nm``) is converted
    first, so that the chain's own unit conversions and transformations then apply to it as
    to a signal. A connector without a declared unit leaves the value's unit to the compiler,
    which converts it to the unit of the component variable it reaches.
    """
    connector = graph.connectors.get(pin)
    target = graph.document.units.get(connector.unit) if connector and connector.unit else None
    unit = value.unit
    number = value.value
    if unit is None or target is None or isinstance(number, bool):
        return value
    if not isinstance(number, int | float):
        return value
    if unit.exponents != target.exponents:
        graph.bag.emit(
            codes.UNIT,
            f"`{value.name}` is given in `{unit.name}`, which measures another quantity than "
            f"connector `{pin[1]}` (`{connector.unit if connector else ''}`)",
            value.span,
        )
        return value
    converted = (unit.factor * number + unit.offset - target.offset) / target.factor
    return replace(value, value=converted, unit=None)


def _resolve(graph: SystemGraph, path: tuple[str, ...], name: str) -> tuple[Pin, bool] | None:
    """The pin ``name`` means on the system at ``path`` and whether it is a system connector.

    The system's own connector first; then the element inside it with the longest dotted
    name that prefixes ``name``: a nested system with that connector, or a component.
    """
    if (path, name) in graph.connectors:
        return (path, name), True
    best: tuple[Pin, bool] | None = None
    best_length = -1
    for inner, element in graph.paths.items():
        if inner[: len(path)] != path or len(inner) == len(path):
            continue
        relative = ".".join(inner[len(path) :])
        if not name.startswith(relative + ".") or len(relative) <= best_length:
            continue
        rest = name[len(relative) + 1 :]
        if element.is_system and (inner, rest) in graph.connectors:
            best, best_length = ((inner, rest), True), len(relative)
        elif not element.is_system:
            best, best_length = ((inner, rest), False), len(relative)
    return best


def _transformed(graph: SystemGraph, value: BoundValue, end: Reached) -> ScalarLiteral | None:
    """The value as it arrives at ``end``: the chain's transformation applied to numbers."""
    if end.identity:
        return value.value
    number = value.value
    if not is_number(number):
        graph.bag.emit(
            codes.SSP_UNSUPPORTED,
            f"`{value.name}` reaches `{'.'.join(end.pin[0])}.{end.pin[1]}` through a linear "
            "transformation, which applies to Real and Integer values only",
            value.span,
        )
        return None
    return end.factor * number + end.offset


def _downstream(graph: SystemGraph, pin: Pin) -> set[Pin]:
    """``pin`` and the system connectors its connections pass through."""
    found = {pin}
    stack = [pin]
    while stack:
        for edge in graph.edges.get(stack.pop(), []):
            if graph.is_system_pin(edge.end) and edge.end not in found:
                found.add(edge.end)
                stack.append(edge.end)
    return found
