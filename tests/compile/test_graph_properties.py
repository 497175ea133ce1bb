"""Property tests of the graph stage: order, loop detection, period arithmetic."""

from __future__ import annotations

from pathlib import Path

import networkx as nx
from hypothesis import given, settings
from hypothesis import strategies as st

from fmionnx.compile.graph import (
    cycle_through,
    earliest_first_order,
    execution_order,
    find_algebraic_loops,
    strongly_connected_parts,
)
from fmionnx.compile.ir import Connection
from fmionnx.core.types import (
    Causality,
    Component,
    ComponentInterface,
    DType,
    Port,
    PortRef,
    is_whole_multiple,
)
from fmionnx.kinds.fmu.kind import FmuConfig


def _component(name: str, feedthrough: bool) -> Component:
    ports = (
        Port("u", Causality.INPUT, DType.FLOAT64),
        Port("y", Causality.OUTPUT, DType.FLOAT64, depends_on=("u",) if feedthrough else ()),
    )
    interface = ComponentInterface("fmu", Path(f"{name}.fmu"), ports)
    return Component(name, "fmu", Path(f"{name}.fmu"), interface, FmuConfig(), 0.1, 1)


def _connect(a: Component, b: Component) -> Connection:
    return Connection(PortRef(a.name, "y"), PortRef(b.name, "u"), a.port("y"), b.port("u"), 1)


systems = st.integers(min_value=1, max_value=7).flatmap(
    lambda n: st.tuples(
        st.lists(st.booleans(), min_size=n, max_size=n),
        st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=2 * n),
    )
)


@given(systems)
@settings(max_examples=200, deadline=None)
def test_order_is_a_permutation_respecting_every_uncut_edge(
    system: tuple[list[bool], list[tuple[int, int]]],
) -> None:
    feedthrough, edges = system
    components = [_component(f"c{i}", f) for i, f in enumerate(feedthrough)]
    # one driver per input: keep the first edge into each component
    seen: set[int] = set()
    connections = []
    for a, b in edges:
        if a != b and b not in seen:
            seen.add(b)
            connections.append(_connect(components[a], components[b]))
    order = execution_order(components, connections)
    assert sorted(order) == sorted(c.name for c in components)
    loops = find_algebraic_loops(components, connections)
    if loops:
        return
    position = {name: i for i, name in enumerate(order)}
    graph = nx.DiGraph([(c.src.component, c.dst.component) for c in connections])
    for connection in connections:
        a, b = connection.src.component, connection.dst.component
        in_cycle = nx.has_path(graph, b, a)
        if not in_cycle:
            assert position[a] < position[b], (order, a, b)


@given(st.lists(st.booleans(), min_size=2, max_size=6))
def test_a_ring_is_an_algebraic_loop_exactly_when_every_member_feeds_through(
    feedthrough: list[bool],
) -> None:
    components = [_component(f"c{i}", f) for i, f in enumerate(feedthrough)]
    ring = [
        _connect(components[i], components[(i + 1) % len(components)])
        for i in range(len(components))
    ]
    loops = find_algebraic_loops(components, ring)
    assert bool(loops) == all(feedthrough)


@given(st.integers(1, 10_000), st.sampled_from([1e-4, 1e-3, 2e-3, 0.01, 0.1]))
def test_whole_multiples_are_recognised(k: int, step: float) -> None:
    assert is_whole_multiple(k * step, step) == k


@given(st.floats(0.1, 0.9), st.sampled_from([1e-3, 0.01, 0.1]))
def test_fractional_multiples_are_rejected(fraction: float, step: float) -> None:
    assert is_whole_multiple((3 + fraction) * step, step) is None


# The compile's own graph algorithms (compile/graph.py), held to networkx's answers on random
# directed graphs: networkx is no longer imported by a compile, so these are what order it.

digraphs = st.integers(min_value=1, max_value=9).flatmap(
    lambda n: st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=3 * n).map(
        lambda edges: (n, edges)
    )
)


def _both(n: int, edges: list[tuple[int, int]]) -> tuple[dict[int, dict[int, None]], nx.DiGraph]:
    ours: dict[int, dict[int, None]] = {node: {} for node in range(n)}
    theirs = nx.DiGraph()
    theirs.add_nodes_from(range(n))
    for a, b in edges:
        ours[a][b] = None
        theirs.add_edge(a, b)
    return ours, theirs


@given(digraphs)
@settings(max_examples=300, deadline=None)
def test_strongly_connected_parts_are_networkx_s(graph: tuple[int, list[tuple[int, int]]]) -> None:
    ours, theirs = _both(*graph)
    found = sorted(sorted(part) for part in strongly_connected_parts(ours))
    assert found == sorted(sorted(part) for part in nx.strongly_connected_components(theirs))


@given(digraphs)
@settings(max_examples=300, deadline=None)
def test_the_cycle_through_a_part_is_networkx_s(graph: tuple[int, list[tuple[int, int]]]) -> None:
    """The same cycle, not only a cycle: loop errors (E035) name it."""
    ours, theirs = _both(*graph)
    for part in strongly_connected_parts(ours):
        if len(part) > 1:
            start = min(part)
            expected = nx.find_cycle(theirs.subgraph(part), source=start)
            assert cycle_through(ours, part, start) == [tuple(edge) for edge in expected]


@given(digraphs)
@settings(max_examples=300, deadline=None)
def test_the_earliest_first_order_is_networkx_s(graph: tuple[int, list[tuple[int, int]]]) -> None:
    ours, theirs = _both(*graph)
    rank = {node: (node * 7) % 11 for node in range(graph[0])}  # not the nodes' own order
    found = earliest_first_order(ours, rank.__getitem__)
    if nx.is_directed_acyclic_graph(theirs):
        expected = list(nx.lexicographical_topological_sort(theirs, key=rank.__getitem__))
        assert found == expected
    else:
        assert found is None
