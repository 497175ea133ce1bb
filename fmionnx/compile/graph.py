"""The dataflow graph: algebraic-loop detection and the execution order within a step.

Semantics (documented in ``docs/execution.md``): at a communication point, the components that
are due run one after another in :attr:`CompiledSystem.order`; each reads the newest value of
every input (from a producer that already ran at this point, else the value it published
before) and publishes its outputs at the end of its step.

* An output *depends directly* on the inputs in its ``depends_on`` (``None`` = unknown = all
  inputs of its component). A cycle through such dependencies is an algebraic loop (E035).
* Order: producers before consumers. Inside a cycle, an edge whose source output has no
  direct dependency (a state, e.g. a MuJoCo sensor or an integrator) is cut: its consumer
  reads the value published at the end of the producer's previous step, which is the value at
  the current time. Ties are broken by declaration order, so the order is deterministic.

The three graph algorithms the compile needs (strongly connected parts, one cycle through a
part, the topological order that takes the earliest declared component first) are written
here, on plain dicts: networkx took a fifth of a second to import in every compile that was
not served from the cache. :func:`dataflow_graph`, for the ``graph`` command's export, still
builds a networkx graph. ``tests/compile/test_graph_properties.py`` holds these functions to
networkx's answers.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Hashable, Iterable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, TypeVar

from fmionnx.compile.ir import CompiledSystem, Connection
from fmionnx.core.types import Causality, Component, Port

if TYPE_CHECKING:
    import networkx as nx

N = TypeVar("N", bound=Hashable)
#: A directed graph: each node's successors, in the order their edges were first added (a
#: dict as an ordered set), so that every walk over it is the same in every process.
Digraph = dict[N, dict[N, None]]
#: A port of the feedthrough graph: (component, port).
PortNode = tuple[str, str]


def _add_edge(graph: Digraph[N], a: N, b: N) -> None:
    graph.setdefault(a, {})[b] = None
    graph.setdefault(b, {})


def strongly_connected_parts(graph: Mapping[N, Mapping[N, None]]) -> list[set[N]]:
    """The strongly connected parts of ``graph`` (Tarjan's algorithm, without recursion)."""
    index: dict[N, int] = {}
    low: dict[N, int] = {}
    stack: list[N] = []
    on_stack: set[N] = set()
    parts: list[set[N]] = []
    for root in graph:
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        walk: list[tuple[N, Iterator[N]]] = [(root, iter(graph[root]))]
        while walk:
            node, successors = walk[-1]
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    walk.append((successor, iter(graph[successor])))
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            else:
                walk.pop()
                if walk:
                    parent = walk[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    part: set[N] = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        part.add(member)
                        if member == node:
                            break
                    parts.append(part)
    return parts


def cycle_through(graph: Mapping[N, Mapping[N, None]], part: set[N], start: N) -> list[tuple[N, N]]:
    """The first cycle a depth-first walk from ``start`` inside ``part`` closes, as its edges
    from the node it closes on; successors are tried in the order of their edges.

    ``part`` is a strongly connected part with a cycle, so the walk always closes one. The
    same cycle as ``networkx.find_cycle(graph.subgraph(part), source=start)``.
    """
    path: list[N] = [start]
    on_path = {start: 0}
    finished: set[N] = set()
    walk: list[Iterator[N]] = [iter(graph[start])]
    while walk:
        node = path[-1]
        for successor in walk[-1]:
            if successor not in part or successor in finished:
                continue
            if successor in on_path:
                loop = [*path[on_path[successor] :], successor]
                return list(itertools.pairwise(loop))
            on_path[successor] = len(path)
            path.append(successor)
            walk.append(iter(graph[successor]))
            break
        else:
            walk.pop()
            finished.add(path.pop())
            del on_path[node]
    raise ValueError(f"no cycle through {start!r}")  # not a part with a cycle: a caller's bug


def earliest_first_order(
    graph: Mapping[N, Mapping[N, None]], key: Callable[[N], int]
) -> list[N] | None:
    """A topological order of ``graph`` that takes, of the nodes whose predecessors are all
    placed, the one of the smallest ``key`` first (unique keys: one answer); ``None`` if the
    graph has a cycle."""
    waiting = dict.fromkeys(graph, 0)
    for successors in graph.values():
        for successor in successors:
            waiting[successor] += 1
    ready = [(key(node), node) for node, count in waiting.items() if count == 0]
    heapq.heapify(ready)
    order: list[N] = []
    while ready:
        _, node = heapq.heappop(ready)
        order.append(node)
        for successor in graph[node]:
            waiting[successor] -= 1
            if waiting[successor] == 0:
                heapq.heappush(ready, (key(successor), successor))
    return order if len(order) == len(waiting) else None


def direct_inputs(component: Component, output: Port) -> tuple[str, ...]:
    """Names of the inputs ``output`` depends on directly (all inputs when unknown)."""
    if output.depends_on is not None:
        return output.depends_on
    return tuple(p.name for p in component.interface.with_causality(Causality.INPUT))


def _feedthrough_graph(
    components: Sequence[Component], connections: Iterable[Connection]
) -> tuple[Digraph[PortNode], dict[PortNode, int]]:
    """Port-level graph: connections, and each used output's direct dependencies; with each
    used output's rank (the position of its first connection)."""
    by_name = {c.name: c for c in components}
    graph: Digraph[PortNode] = {}
    used_outputs: dict[PortNode, int] = {}  # a dict: insertion order, not hash order
    for rank, connection in enumerate(connections):
        src = (connection.src.component, connection.src.port)
        _add_edge(graph, src, (connection.dst.component, connection.dst.port))
        used_outputs.setdefault(src, rank)
    for component_name, port_name in used_outputs:
        component = by_name[component_name]
        output = component.port(port_name)
        for input_name in direct_inputs(component, output):
            _add_edge(graph, (component_name, input_name), (component_name, port_name))
    return graph, used_outputs


def _loop_parts(
    graph: Digraph[PortNode], ranks: Mapping[PortNode, int]
) -> list[tuple[set[str], list[str]]]:
    """Each strongly connected part with a cycle: its components and one cycle (``comp.port``)."""
    parts = []
    for scc in strongly_connected_parts(graph):
        if len(scc) > 1:
            # from the output of the part's first declared connection, so that the cycle
            # named does not depend on the order of a set (string hashes vary per process)
            start = min((node for node in scc if node in ranks), key=ranks.__getitem__)
            cycle = cycle_through(graph, scc, start)
            names = [f"{edge[0][0]}.{edge[0][1]}" for edge in cycle]
            parts.append(({component for component, _ in scc}, names))
    return parts


def find_algebraic_loops(
    components: Sequence[Component], connections: Iterable[Connection]
) -> list[list[str]]:
    """Cycles through direct-feedthrough ports, each as a list of ``comp.port`` names."""
    connections = list(connections)
    if not connections:  # no edge, no cycle
        return []
    return sorted(cycle for _, cycle in _loop_parts(*_feedthrough_graph(components, connections)))


def loop_groups(
    components: Sequence[Component], connections: Iterable[Connection]
) -> list[tuple[tuple[str, ...], list[str]]]:
    """The algebraic loops as component sets: (members in declaration order, one cycle).

    Loops that share a component are one group: stepping that component once per iteration
    serves both, so they are solved together. Groups are sorted by their first member.
    """
    connections = list(connections)
    if not connections:  # no edge, no cycle
        return []
    position = {c.name: i for i, c in enumerate(components)}
    merged: list[tuple[set[str], list[str]]] = []
    for part, cycle in sorted(
        _loop_parts(*_feedthrough_graph(components, connections)), key=lambda p: p[1]
    ):
        members = set(part)
        touching = [group for group in merged if group[0] & members]
        for group in touching:
            merged.remove(group)
            members |= group[0]
        first = touching[0][1] if touching else cycle
        merged.append((members, first))
    groups = [
        (tuple(sorted(members, key=position.__getitem__)), cycle) for members, cycle in merged
    ]
    return sorted(groups, key=lambda g: position[g[0][0]])


def execution_order(
    components: Sequence[Component], connections: Sequence[Connection]
) -> tuple[str, ...]:
    """Topological order of components, cutting edges from non-feedthrough outputs in cycles.

    Cycles left after the cut are algebraic loops (errors reported elsewhere): then the
    declaration order. The same ordering as :func:`execution_order_with_loops` without loops.
    """
    return execution_order_with_loops(components, connections, ())


def dataflow_graph(system: CompiledSystem) -> nx.MultiDiGraph:
    """Component-level multigraph: nodes carry kind/period/path, edges carry the ports."""
    import networkx as nx

    graph: nx.MultiDiGraph = nx.MultiDiGraph(name=system.name)
    for component in system.components:
        graph.add_node(
            component.name,
            kind=component.kind,
            period=component.period,
            path=str(component.path),
            external=component.external,
        )
    for connection in system.connections:
        graph.add_edge(
            connection.src.component,
            connection.dst.component,
            src=str(connection.src),
            dst=str(connection.dst),
            src_port=connection.src.port_label,
            dst_port=connection.dst.port_label,
            dtype=str(connection.src_port.dtype),
            size=connection.size,
        )
    return graph


def execution_order_with_loops(
    components: Sequence[Component],
    connections: Sequence[Connection],
    loops: Sequence[Sequence[str]],
) -> tuple[str, ...]:
    """:func:`execution_order` with each iterated loop's members kept together.

    Each loop is one node of the ordering (its members' edges are its edges); the loop's
    members then take its place, in the loop's own order. Edges from non-feedthrough outputs
    are cut inside cycles as in :func:`execution_order`.
    """
    if not connections and not loops:  # nothing to sort: the declaration order
        return tuple(c.name for c in components)
    position = {c.name: i for i, c in enumerate(components)}
    by_name = {c.name: c for c in components}
    node_of = {c.name: c.name for c in components}
    members_of: dict[str, Sequence[str]] = {}
    for loop in loops:
        head = min(loop, key=position.__getitem__)
        members_of[head] = loop
        for member in loop:
            node_of[member] = head
    graph: Digraph[str] = {node: {} for node in node_of.values()}
    delayed: set[tuple[str, str]] = set()
    for connection in connections:
        a, b = node_of[connection.src.component], node_of[connection.dst.component]
        if a == b:
            continue
        _add_edge(graph, a, b)
        source = by_name[connection.src.component]
        if not direct_inputs(source, source.port(connection.src.port)):
            delayed.add((a, b))
    part_of = {node: i for i, part in enumerate(strongly_connected_parts(graph)) for node in part}
    for a, b in delayed:  # inside a cycle only: elsewhere the edge orders as it is
        if part_of[a] == part_of[b]:
            graph[a].pop(b, None)
    nodes = earliest_first_order(graph, position.__getitem__)
    if nodes is None:  # a component-level cycle that is no port-level loop: declaration order
        nodes = sorted(graph, key=position.__getitem__)
    order: list[str] = []
    for node in nodes:
        order.extend(members_of.get(node, (node,)))
    return tuple(order)
