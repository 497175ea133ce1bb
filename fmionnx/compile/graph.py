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
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import networkx as nx

from fmionnx.compile.ir import CompiledSystem, Connection
from fmionnx.core.types import Causality, Component, Port


def direct_inputs(component: Component, output: Port) -> tuple[str, ...]:
    """Names of the inputs ``output`` depends on directly (all inputs when unknown)."""
    if output.depends_on is not None:
        return output.depends_on
    return tuple(p.name for p in component.interface.with_causality(Causality.INPUT))


def find_algebraic_loops(
    components: Sequence[Component], connections: Iterable[Connection]
) -> list[list[str]]:
    """Cycles through direct-feedthrough ports, each as a list of ``comp.port`` names."""
    by_name = {c.name: c for c in components}
    graph: nx.DiGraph = nx.DiGraph()
    used_outputs: set[tuple[str, str]] = set()
    for connection in connections:
        src = f"{connection.src.component}.{connection.src.port}"
        dst = f"{connection.dst.component}.{connection.dst.port}"
        graph.add_edge(src, dst)
        used_outputs.add((connection.src.component, connection.src.port))
    for component_name, port_name in used_outputs:
        component = by_name[component_name]
        output = component.port(port_name)
        for input_name in direct_inputs(component, output):
            graph.add_edge(f"{component_name}.{input_name}", f"{component_name}.{port_name}")
    loops = []
    for scc in nx.strongly_connected_components(graph):
        if len(scc) > 1:
            cycle = nx.find_cycle(graph.subgraph(scc))
            loops.append([edge[0] for edge in cycle])
    return sorted(loops)


def execution_order(
    components: Sequence[Component], connections: Sequence[Connection]
) -> tuple[str, ...]:
    """Topological order of components, cutting edges from non-feedthrough outputs in cycles."""
    position = {c.name: i for i, c in enumerate(components)}
    by_name = {c.name: c for c in components}
    graph: nx.DiGraph = nx.DiGraph()
    graph.add_nodes_from(position)
    delayed: set[tuple[str, str]] = set()
    for connection in connections:
        a, b = connection.src.component, connection.dst.component
        if a == b:
            continue
        graph.add_edge(a, b)
        output = by_name[a].port(connection.src.port)
        if not direct_inputs(by_name[a], output):
            delayed.add((a, b))
    for scc in list(nx.strongly_connected_components(graph)):
        if len(scc) < 2:
            continue
        for a, b in list(graph.subgraph(scc).edges):
            if (a, b) in delayed:
                graph.remove_edge(a, b)
    if not nx.is_directed_acyclic_graph(graph):
        # Remaining cycles are algebraic loops, reported as errors elsewhere.
        return tuple(c.name for c in components)
    return tuple(nx.lexicographical_topological_sort(graph, key=lambda n: f"{position[n]:08d}"))


def dataflow_graph(system: CompiledSystem) -> nx.MultiDiGraph:
    """Component-level multigraph: nodes carry kind/period/path, edges carry the ports."""
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
