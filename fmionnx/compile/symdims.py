"""Symbolic ONNX dimensions across a component: what its connected inputs fix, checked at
every connection of its ports.

Each connection's count is checked on its own (:func:`~.typecheck.check_count`): a symbolic
dimension matches any count the fixed ones divide. But a name is one number in the whole
model (``x: [batch, 3]`` fed six elements makes ``y: [batch, 3]`` six too), so a system could
validate and then fault at its first step. Here the counts fed to each component's inputs fix
its names (:mod:`fmionnx.core.dims`, the rule the runner shapes its tensors by), and
an input left ambiguous, or a connection whose count the fixed shape does not give, is E032
at the connection.
"""

from __future__ import annotations

from collections import defaultdict

from fmionnx.compile.ir import Connection
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.dims import Dims, bind_dims, known_count, resolved_shape
from fmionnx.core.types import Causality, Component

_HINT = "connect counts the model's shape can take, or give the model fixed dimensions"


def check_symbolic_dims(
    components: list[Component], connections: list[Connection], bag: DiagnosticBag
) -> None:
    """E032 for each input whose count leaves its shape ambiguous or contradicts a name
    another input fixed, and for each connection from an output whose count, once its names
    are fixed, differs from what the connection carries."""
    incoming: dict[str, list[Connection]] = defaultdict(list)
    outgoing: dict[str, list[Connection]] = defaultdict(list)
    for connection in connections:
        incoming[connection.dst.component].append(connection)
        outgoing[connection.src.component].append(connection)
    for component in components:
        ports = component.interface.ports
        if all(isinstance(d, int) for p in ports for d in p.shape):
            continue
        sizes: dict[str, int] = {}
        spans: dict[str, Span | None] = {}
        for connection in incoming[component.name]:  # summed as the runtime sizes buffers
            name = connection.dst.port
            sizes[name] = sizes.get(name, 0) + connection.size
            spans.setdefault(name, connection.span)
        dims = bind_dims(ports, sizes)
        for problem in dims.problems:
            message = f"`{component.name}.{problem.port}`: {problem.message}"
            bag.emit(codes.SHAPE, message, spans.get(problem.port), hint=_HINT)
        if not dims.problems:
            _check_outputs(component, outgoing[component.name], dims, bag)


def _check_outputs(
    component: Component, connections: list[Connection], dims: Dims, bag: DiagnosticBag
) -> None:
    for connection in connections:
        port = connection.src_port
        if connection.src.index is not None or port.causality is not Causality.OUTPUT:
            continue
        if all(isinstance(d, int) for d in port.shape):
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
