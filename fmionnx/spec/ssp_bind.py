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

Bindings are applied innermost element first, so that the values of outer systems override
those of inner systems and components; within one element a later binding overrides an
earlier one. SSP gives a system connector no start value of its own (``ssc:Real`` has a
``unit`` and nothing else, in 1.0 and 2.0): its value comes from a binding or from a
connection.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core.specbase import ScalarLiteral
from fmionnx.spec.ssp_graph import Pin, Reached, SystemGraph, system_text
from fmionnx.spec.ssp_params import BoundValue, binding_values
from fmionnx.spec.ssp_tree import Element

Parameters = dict[str, dict[str, BoundValue]]


def bind_parameters(graph: SystemGraph, root: Path | None, parameters: Parameters) -> set[Pin]:
    """Fill ``parameters`` (component -> name -> value); return the system connectors set."""
    bound: set[Pin] = set()
    # Innermost first, so that outer bindings (applied later) override them.
    for path, element in sorted(graph.elements, key=lambda item: -len(item[0])):
        for binding in element.bindings:
            for value in binding_values(binding, graph.ssd, root, graph.bag):
                if not element.is_system:
                    parameters[".".join(path)][value.name] = value
                    continue
                pin = _assign(graph, path, element, value, parameters)
                if pin is not None:
                    bound |= _downstream(graph, pin)
    return bound


def _assign(
    graph: SystemGraph,
    path: tuple[str, ...],
    element: Element,
    value: BoundValue,
    parameters: Parameters,
) -> Pin | None:
    """Set ``value`` bound on the system at ``path``; the system connector it set, if any."""
    target = _resolve(graph, path, value.name)
    if target is None:
        graph.bag.emit(
            "E072",
            f"parameter `{value.name}` bound on system `{element.name}` names no component "
            "or system connector inside it",
            value.span,
            hint="name a connector of the system (`k`), of a nested system (`sub.k`), or a "
            "component's parameter (`gain.k`); or give the binding a `prefix`",
        )
        return None
    pin, is_connector = target
    if not is_connector:
        parameters[".".join(pin[0])][pin[1]] = BoundValue(pin[1], value.value, value.span)
        return None
    reached = graph.reach_from(pin)
    if not reached and not graph.broken:
        graph.bag.emit(
            "W070",
            f"`{value.name}` sets connector `{pin[1]}` of "
            f"{system_text(pin[0], graph.root_name)}, which leads to no component connector; "
            "the value is not used",
            value.span,
        )
    for end in reached:
        result = _transformed(graph, value, end)
        if result is not None:
            component = ".".join(end.pin[0])
            parameters[component][end.pin[1]] = BoundValue(end.pin[1], result, value.span)
    return pin


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
    if isinstance(number, bool) or not isinstance(number, int | float):
        graph.bag.emit(
            "E071",
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
