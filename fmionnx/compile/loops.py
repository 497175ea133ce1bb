"""Algebraic loops: refused by default (E035), resolved for iteration when the system asks.

A cycle through direct-feedthrough ports has no value the Gauss-Seidel order could compute
in one pass. Without ``run.algebraic_loops`` it is error E035, naming the cycle. With it, each
loop (components whose ports form a strongly connected part of the feedthrough graph; loops
sharing a component merged) becomes an :class:`AlgebraicLoop` of the compiled system: its
members in declaration order, the inputs that read a later member's output (the tear
variables the run iterates) and the solver settings. The loop is solvable only when every
member can repeat a step from a saved state (E051), the members share one period (E052) and
the iterated values are floating-point numbers (E053). ``docs/execution.md`` has the rule.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fmionnx.compile.graph import direct_inputs, find_algebraic_loops, loop_groups
from fmionnx.compile.ir import AlgebraicLoop, Connection, LoopSolver
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span
from fmionnx.core.types import Component, PortRef
from fmionnx.kinds.base import Repeatable
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.runspec import AlgebraicLoopsSpec
from fmionnx.spec.sourcemap import SourceMap

#: What E035 suggests besides breaking the loop.
ITERATE_HINT = (
    "break the loop with a component whose output does not depend directly on its input (a "
    "delay, a state), declare the dependencies in the model, or have it solved by iteration: "
    "`run: {algebraic_loops: {solver: newton}}`"
)


def compile_loops(
    components: Sequence[Component],
    connections: Sequence[Connection],
    settings: AlgebraicLoopsSpec | None,
    system_file: Path,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[AlgebraicLoop, ...]:
    """The loops to iterate (none without ``settings``); problems go to ``bag``."""
    if settings is None:
        for cycle in find_algebraic_loops(components, connections):
            spans = _cycle_spans(cycle, connections)
            bag.emit(
                codes.ALGEBRAIC_LOOP,
                "algebraic loop: " + " -> ".join([*cycle, cycle[0]]),
                spans[0] if spans else Span(system_file),
                hint=ITERATE_HINT,
                notes=[Note("part of the loop", s) for s in spans[1:]],
            )
        return ()
    solver = LoopSolver(
        settings.solver, settings.tolerance, settings.max_iterations, settings.relaxation
    )
    by_name = {c.name: c for c in components}
    setting_span = sources.key(("run", "algebraic_loops"))
    loops = []
    for members, cycle in loop_groups(components, connections):
        loop = AlgebraicLoop(members, _tears(members, connections, by_name), tuple(cycle), solver)
        spans = _cycle_spans(cycle, connections)
        where = spans[0] if spans else Span(system_file)
        notes = [Note("iteration requested here", setting_span)]
        ok = _check_members(loop, by_name, where, notes, bag)
        ok = _check_values(loop, connections, where, notes, bag) and ok
        if ok:
            loops.append(loop)
    return tuple(loops)


def _cycle_spans(cycle: list[str], connections: Sequence[Connection]) -> list[Span]:
    """Where the connections that are edges of ``cycle`` are written, in declaration order.

    ``cycle`` lists the ports the loop passes through (``comp.port``, each followed by the
    next, the last by the first); a connection is part of the loop only when it leads from
    one port of the cycle to the port after it. Another connection leaving a looping output
    (its value also goes elsewhere) is not: marking it would send the user to the wrong line.
    """
    edges = set(zip(cycle, [*cycle[1:], cycle[0]], strict=True))
    return [
        c.span
        for c in connections
        if c.span is not None
        and (f"{c.src.component}.{c.src.port}", f"{c.dst.component}.{c.dst.port}") in edges
    ]


def _tears(
    members: tuple[str, ...], connections: Sequence[Connection], by_name: dict[str, Component]
) -> tuple[PortRef, ...]:
    """Inputs fed by a member stepped later (or by themselves) through a feedthrough output."""
    position = {name: i for i, name in enumerate(members)}
    tears = []
    for connection in connections:
        src, dst = connection.src.component, connection.dst.component
        if src not in position or dst not in position or position[src] < position[dst]:
            continue
        source = by_name[src]
        if direct_inputs(source, source.port(connection.src.port)):
            tears.append(connection.dst)
    return tuple(tears)


def _check_members(
    loop: AlgebraicLoop,
    by_name: dict[str, Component],
    where: Span,
    notes: list[Note],
    bag: DiagnosticBag,
) -> bool:
    ok = True
    for name in loop.members:
        component = by_name[name]
        kind = COMPONENT_KINDS[component.kind]
        if isinstance(kind, Repeatable):
            problem = kind.repeat_problem(component)
        else:
            problem = f"components of kind `{component.kind}` cannot save and restore their state"
        if problem is not None:
            ok = False
            bag.emit(
                codes.LOOP_ROLLBACK,
                f"component `{name}` is part of the algebraic loop {loop.label}, which is to be "
                f"solved by iteration, but it cannot repeat a step: {problem}",
                component.span or where,
                hint="break the loop instead (a delay, a state), or use a model that can save "
                "and restore its state",
                notes=notes,
            )
    periods = {by_name[name].period_steps for name in loop.members}
    if len(periods) > 1:
        ok = False
        listed = ", ".join(f"`{n}` {by_name[n].period:g} s" for n in loop.members)
        bag.emit(
            codes.LOOP_PERIOD,
            f"the components of the algebraic loop {loop.label} have different periods "
            f"({listed}); an iterated loop steps its members together",
            where,
            hint="give the loop's components one period",
            notes=notes,
        )
    return ok


def _check_values(
    loop: AlgebraicLoop,
    connections: Sequence[Connection],
    where: Span,
    notes: list[Note],
    bag: DiagnosticBag,
) -> bool:
    ok = True
    tears = set(loop.tears)
    for connection in connections:
        if connection.dst not in tears:
            continue
        for port in (connection.src_port, connection.dst_port):
            if not port.dtype.is_float:
                ok = False
                bag.emit(
                    codes.LOOP_VALUES,
                    f"the algebraic loop {loop.label} is iterated on `{connection}`, but "
                    f"`{port.name}` is of type {port.dtype}: only floating-point values "
                    "can be iterated",
                    connection.span or where,
                    hint="break the loop at a floating-point connection, or with a state",
                    notes=notes,
                )
                break
    return ok
