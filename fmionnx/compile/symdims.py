"""Symbolic ONNX dimensions across a system: what each component's connected inputs fix,
checked at every connection of its ports, in dataflow order.

Each connection's count is checked on its own first (:func:`~.typecheck.check_count`): a
symbolic dimension matches any count the fixed ones divide. But a name is one number in the
whole model (``x: [batch, 3]`` fed six elements makes ``y: [batch, 3]`` six too), so a system
could validate and then fault at its first step. Here the counts fed to each component's
inputs fix its names (:mod:`fmionnx.core.dims`, the rule the runner shapes its tensors by), and
an input left ambiguous, or a connection whose count the fixed shape does not give, is E032
at the connection.

A connection whose two ends both have symbolic shapes comes here :data:`UNSIZED`: its count
is the source's once the source's own inputs fixed its names. So components are taken in
dataflow order (a component once every connection into it has a count), and what a source
fixes sizes its connections before the next component's inputs are solved: ``six.y -> d1.x``,
``d1.y -> d2.x`` makes both ``batch`` 2. Refused (E032), as the runner could not size them
either: a connection from an output whose dimension no input names, and connections in a loop
of symbolic components that no fixed count reaches.
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict, deque
from typing import Final

from fmionnx.compile.ir import Connection
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.dims import UNNAMED, Dims, bind_dims, known_count, resolved_shape
from fmionnx.core.types import Causality, Component, Port

#: The size :func:`~.typecheck.check_count` gives a connection between two symbolic shapes:
#: no count yet (never one a connection can carry); :func:`check_symbolic_dims` replaces it
#: or refuses the connection, so no compiled system holds it.
UNSIZED: Final = -1

_HINT = "connect counts the model's shape can take, or give the model fixed dimensions"


def _symbolic(component: Component) -> bool:
    return any(isinstance(d, str) for p in component.interface.ports for d in p.shape)


def check_symbolic_dims(
    components: list[Component], connections: list[Connection], bag: DiagnosticBag
) -> None:
    """E032 for each input whose count leaves its shape ambiguous or contradicts a name
    another input fixed, for each connection from an output whose count, once its names
    are fixed, differs from what the connection carries, and for each connection left
    :data:`UNSIZED`. The connections that were unsized are replaced **in** ``connections``
    by sized ones, so the caller's list is the one the compiled system is made of."""
    incoming: dict[str, list[int]] = defaultdict(list)
    outgoing: dict[str, list[int]] = defaultdict(list)
    unsized = {i for i, c in enumerate(connections) if c.size == UNSIZED}
    waits: dict[str, int] = defaultdict(int)  # unsized connections into a component
    for index, connection in enumerate(connections):
        incoming[connection.dst.component].append(index)
        outgoing[connection.src.component].append(index)
        if index in unsized:
            waits[connection.dst.component] += 1
    symbolic = {c.name: c for c in components if _symbolic(c)}
    ready = deque(c for name, c in symbolic.items() if not waits[name])
    settled: set[str] = set()  # solved, or refused (an error said why)
    while ready:  # dataflow order: a component once every connection into it is sized
        component = ready.popleft()
        settled.add(component.name)
        if all(connections[i].size != UNSIZED for i in incoming[component.name]):
            _solve_component(component, connections, incoming, outgoing, bag)
        # else a source was refused and said why: what it feeds stays unsized, quietly
        for index in outgoing[component.name]:
            if index not in unsized:
                continue
            name = connections[index].dst.component
            waits[name] -= 1
            if not waits[name] and name in symbolic:
                ready.append(symbolic[name])
    for connection in connections:
        if connection.size == UNSIZED and connection.src.component not in settled:
            why = (
                f"nothing fixes the counts fed to `{connection.src.component}`: they come "
                "through a loop of symbolic shapes"
            )
            _unknown_count(connection, why, "give one model of the loop fixed dimensions", bag)


def _solve_component(
    component: Component,
    connections: list[Connection],
    incoming: dict[str, list[int]],
    outgoing: dict[str, list[int]],
    bag: DiagnosticBag,
) -> None:
    """Fix ``component``'s names from the counts fed to its inputs, then size and check the
    connections from its outputs (``incoming``/``outgoing``: indices into ``connections``
    by component)."""
    sizes: dict[str, int] = {}
    spans: dict[str, Span | None] = {}
    for index in incoming[component.name]:  # summed as the runtime sizes buffers
        connection = connections[index]
        name = connection.dst.port
        sizes[name] = sizes.get(name, 0) + connection.size
        spans.setdefault(name, connection.span)
    dims = bind_dims(component.interface.ports, sizes)
    for problem in dims.problems:
        message = f"`{component.name}.{problem.port}`: {problem.message}"
        bag.emit(codes.SHAPE, message, spans.get(problem.port), hint=_HINT)
    if dims.problems:
        return
    mine = outgoing[component.name]
    for index in mine:
        connection = connections[index]
        if connection.size != UNSIZED:
            continue
        count = known_count(resolved_shape(connection.src_port, dims))
        if count is None:
            why = _free_dimensions(connection.src_port, dims, component.name)
            _unknown_count(connection, why, "give the model's output a fixed shape", bag)
        else:
            connections[index] = dataclasses.replace(connection, size=count)
    _check_outputs(component, [connections[i] for i in mine], dims, bag)


def _free_dimensions(port: Port, dims: Dims, component: str) -> str:
    """Why output ``port``'s count stays unknown once ``dims`` are fixed."""
    free = dict.fromkeys(d for d in port.shape if isinstance(d, str) and d not in dims.bound)
    named = [f"`{d}`" for d in free if d != UNNAMED]
    what = [f"{', '.join(named)} named by no input of `{component}`"] if named else []
    if UNNAMED in free:
        what.append("a dimension without a name")
    return f"{port.shape_text()} has {' and '.join(what)}"


def _unknown_count(connection: Connection, why: str, hint: str, bag: DiagnosticBag) -> None:
    bag.emit(
        codes.SHAPE,
        f"both `{connection.src}` and `{connection.dst}` have symbolic shapes and the element "
        f"count is unknown: {why}",
        connection.span,
        hint=hint,
    )


def _check_outputs(
    component: Component, connections: list[Connection], dims: Dims, bag: DiagnosticBag
) -> None:
    for connection in connections:
        port = connection.src_port
        if connection.size == UNSIZED or connection.src.index is not None:
            continue
        if port.causality is not Causality.OUTPUT or all(isinstance(d, int) for d in port.shape):
            continue
        resolved = resolved_shape(port, dims)
        count = known_count(resolved)
        if count is None or count == connection.size:
            continue
        named = [f"{d} = {dims.bound[d]}" for d in port.shape if isinstance(d, str)]
        bag.emit(
            codes.SHAPE,
            f"`{connection.src}` carries {count} element{'s' if count != 1 else ''} "
            f"({port.shape_text()} with {', '.join(named)}, as `{component.name}`'s inputs are "
            f"fed) but `{connection.dst}` takes {connection.size}",
            connection.span,
            hint=_HINT,
        )
