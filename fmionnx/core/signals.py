"""How a port becomes recorded signals: the results columns it fills, and which ports fill none.

The recorder (runtime), the plots resolved at compile time, the checks and the results
writers must agree on one naming, so it lives here, below all of them. An element is named
the way a system file selects it: ``comp.port`` for a scalar, ``comp.port[i]`` (0-based) per
element of a one-dimensional array, and one index per dimension, row-major, for a tensor of
fixed shape (``feedforward.power[0,0]``, ``detector.blobX[0,2]``). A flat index written in a
system file (``power[0]``) selects the same element and is named the same way; a port with a
dimension known only at run time keeps flat indices. docs/running.md, "Results".
"""

from __future__ import annotations

from collections.abc import Iterable

from fmionnx.core.types import Causality, Component, DType, Port, PortRef, flat_index


def is_image(port: Port) -> bool:
    """Camera-like ports (``uint8[H,W,C]``) never go to results.csv."""
    return port.dtype is DType.UINT8 and len(port.shape) >= 2


def element_index(port: Port, flat: int) -> str:
    """The index of element ``flat`` as a system file writes it: ``i``, or ``i,j,...``."""
    shape = port.shape
    if len(shape) < 2 or not all(isinstance(d, int) for d in shape):
        return str(flat)
    indices = []
    for dim in reversed(shape):
        assert isinstance(dim, int)
        flat, i = divmod(flat, dim)
        indices.append(i)
    return ",".join(str(i) for i in reversed(indices))


def column_names(component: str, port: Port, index: tuple[int, ...] | None = None) -> list[str]:
    """``comp.port`` for a scalar, ``comp.port[i]`` or ``comp.port[i,j]`` per element of an
    array (see the module's docstring); ``index`` selects one element (either spelling)."""
    if index is not None:
        return [f"{component}.{port.name}[{element_index(port, flat_index(port, index))}]"]
    if port.is_scalar:
        return [f"{component}.{port.name}"]
    size = port.size
    if size is None:  # a symbolic dimension: one column stands for the port until the run
        size = 1  # knows its count (the recorder then names each element: Track.add)
    # an array of no elements (an FMI 3 dimension of size 0) has no column
    return [f"{component}.{port.name}[{element_index(port, i)}]" for i in range(size)]


def every_output(components: Iterable[Component]) -> tuple[PortRef, ...]:
    """What a run records when the system file does not say (``record:`` absent).

    Other tools record every output by default (OMSimulator, FMPy): a system whose outputs
    feed nothing — a foreign SSP, a system of parameters only, a lone model — must still give
    results. So the default is every output port of every component, whole ports in
    declaration order, component by component, camera images excepted. The compiler resolves
    it into the compiled system (``record``, with ``settings_origin.record`` = ``built-in
    default`` in ``run.json``), so that every backend records the same columns.
    """
    return tuple(
        PortRef(component.name, port.name)
        for component in components
        for port in component.interface.with_causality(Causality.OUTPUT)
        if not is_image(port)
    )
