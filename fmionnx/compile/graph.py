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

networkx is imported by the functions that need a graph: a system without connections (a
single model run as ``fmionnx run model.fmu``) has no loop and is ordered as declared, and
its compile does not pay the library's import.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from fmionnx.compile.ir import CompiledSystem, Connection
from fmionnx.core.types import Causality, Component, Port

if TYPE_CHECKING:
    import networkx as nx


def direct_inputs(component: Component, output: Port) -> tuple[str, ...]:
    """Names of the inputs ``output`` depends on directly (all inputs when unknown)."""
    if output.depends_on is not None:
        return output.depends_on
    return tuple(p.name for p in component.interface.with_causality(Causality.INPUT))


def _feedthrough_graph(
    components: Sequence[Component], connections: Iterable[Connection]
) -> nx.DiGraph:
    """Port-level graph: connections, and each used output's direct dependencies."""
    import networkx as nx

    by_name = {c.name: c for c in components}
    graph: nx.DiGraph = nx.DiGraph()
    used_outputs: dict[tuple[str, str], int] = {}  # a dict: insertion order, not hash order
    for rank, connection in enumerate(connections):
        src = (connection.src.component, connection.src.port)
        graph.add_edge(src, (connection.dst.component, connection.dst.port))
        used_outputs.setdefault(src, rank)
    nx.set_node_attributes(graph, used_outputs, "rank")
    for component_name, port_name in used_outputs:
        component = by_name[component_name]
        output = component.port(port_name)
        for input_name in direct_inputs(component, output):
            graph.add_edge((component_name, input_name), (component_name, port_name))
    return graph


def _loop_parts(graph: nx.DiGraph) -> list[tuple[set[str], list[str]]]:
    """Each strongly connected part with a cycle: its components and one cycle (``comp.port``)."""
    import networkx as nx

    parts = []
    ranks = nx.get_node_attributes(graph, "rank")
    for scc in nx.strongly_connected_components(graph):
        if len(scc) > 1:
            # from the output of the part's first declared connection, so that the cycle
            # named does not depend on the order of a set (string hashes vary per process)
            start = min((node for node in scc if node in ranks), key=ranks.__getitem__)
            cycle = nx.find_cycle(graph.subgraph(scc), source=start)
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
    graph = _feedthrough_graph(components, connections)
    return sorted(cycle for _, cycle in _loop_parts(graph))


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
        _loop_parts(_feedthrough_graph(components, connections)), key=lambda p: p[1]
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
    import networkx as nx

    position = {c.name: i for i, c in enumerate(components)}
    by_name = {c.name: c for c in components}
    node_of = {c.name: c.name for c in components}
    members_of: dict[str, Sequence[str]] = {}
    for loop in loops:
        head = min(loop, key=position.__getitem__)
        members_of[head] = loop
        for member in loop:
            node_of[member] = head
    graph: nx.DiGraph = nx.DiGraph()
    graph.add_nodes_from(set(node_of.values()))
    delayed: set[tuple[str, str]] = set()
    for connection in connections:
        a, b = node_of[connection.src.component], node_of[connection.dst.component]
        if a == b:
            continue
        graph.add_edge(a, b)
        source = by_name[connection.src.component]
        if not direct_inputs(source, source.port(connection.src.port)):
            delayed.add((a, b))
    for scc in list(nx.strongly_connected_components(graph)):
        if len(scc) < 2:
            continue
        for a, b in list(graph.subgraph(scc).edges):
            if (a, b) in delayed:
                graph.remove_edge(a, b)
    if nx.is_directed_acyclic_graph(graph):
        nodes = list(nx.lexicographical_topological_sort(graph, key=lambda n: f"{position[n]:08d}"))
    else:  # a component-level cycle that is no port-level loop: declaration order
        nodes = sorted(graph.nodes, key=position.__getitem__)
    order: list[str] = []
    for node in nodes:
        order.extend(members_of.get(node, (node,)))
    return tuple(order)
