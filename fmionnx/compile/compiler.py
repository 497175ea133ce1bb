"""The compiler: raw spec + real model interfaces -> checked, frozen :class:`CompiledSystem`.

Stages collect diagnostics into one bag, so a single run reports every problem; a stage that
cannot continue for one component or connection skips just that item.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from fmionnx.compile.checks import compile_checks
from fmionnx.compile.components import compile_component
from fmionnx.compile.endpoints import (
    ResolvedEndpoint,
    resolve_endpoint,
    split_endpoint,
)
from fmionnx.compile.graph import execution_order, execution_order_with_loops
from fmionnx.compile.ir import CompiledSystem, Connection, Origin, SystemInput
from fmionnx.compile.loops import compile_loops
from fmionnx.compile.overrides import (
    OverrideError,
    override_parameter,
    target_dtype,
    transformation_text,
    transformed,
)
from fmionnx.compile.plots import compile_plots
from fmionnx.compile.recordcheck import recorded_refs
from fmionnx.compile.resolve import read_interface, resolve_run
from fmionnx.compile.symdims import check_symbolic_dims
from fmionnx.compile.sysinputs import compile_inputs
from fmionnx.compile.typecheck import check_causality, check_count, check_dtype
from fmionnx.compile.unitcheck import check_units
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Severity, Span
from fmionnx.core.signals import every_output
from fmionnx.core.sourcetext import source_lines
from fmionnx.core.types import (
    Causality,
    Component,
    ComponentInterface,
    Port,
    ValueSource,
    flat_index,
    is_number,
)
from fmionnx.spec.model import ConnectionSpec, SystemSpec, split_connection
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.suffixes import SSP_SUFFIXES
from fmionnx.spec.yaml import LoadedSpec


def compile_spec(loaded: LoadedSpec, bag: DiagnosticBag) -> CompiledSystem | None:
    """Compile a loaded spec; returns None when errors make a system impossible."""
    spec = loaded.spec
    if spec is None:
        return None
    sources = loaded.sources
    interfaces: dict[str, ComponentInterface | None] = {}
    for name, component_spec in spec.components.items():
        interfaces[name] = read_interface(name, component_spec, loaded.path, sources, bag)
    readable = {n: i for n, i in interfaces.items() if i is not None}
    periods = {n: s.period for n, s in spec.components.items() if s.period is not None}
    from_ssp = loaded.path.suffix.lower() in SSP_SUFFIXES  # SSP has no step size of its own
    run = resolve_run(spec.run, readable, periods, sources, bag, fallback_step=from_ssp)

    components: list[Component] = []
    for name, component_spec in spec.components.items():
        interface = interfaces[name]
        if interface is None:
            continue
        components.append(
            compile_component(name, component_spec, interface, run, loaded.path, sources, bag)
        )

    mentioned: set[tuple[str, str]] = set()
    connections = _connections(spec, interfaces, sources, bag, mentioned)
    by_name = {c.name: c for c in components}
    _check_drivers(connections, bag)
    check_symbolic_dims(components, connections, bag)
    inputs = compile_inputs(spec, interfaces, sources, bag)
    # A port a system input reaches is set from outside, like a connected one.
    mentioned |= {(t.ref.component, t.ref.port) for i in inputs for t in i.targets}
    _check_unconnected(components, mentioned, spec, sources, bag)
    usable = [c for c in connections if c.src.component in by_name and c.dst.component in by_name]
    loops = compile_loops(components, usable, spec.run.algebraic_loops, loaded.path, sources, bag)
    # Declared components whose model could not be read (E010-E019 said why): what names
    # them below is skipped without a word, never called an unknown component.
    unreadable = frozenset(name for name, interface in interfaces.items() if interface is None)
    if spec.record is not None:
        record = tuple(recorded_refs(spec.record, by_name, unreadable, sources, bag))
    else:  # other tools' default: every output (images excepted), resolved here for all
        record = every_output(components)
        if run is not None:
            origins = (*run.origins, ("record", Origin.BUILTIN_DEFAULT))
            run = dataclasses.replace(run, origins=origins)
    plots = compile_plots(spec, by_name, sources, bag, unreadable=unreadable)
    checks = compile_checks(spec.checks, by_name, sources, bag, unreadable=unreadable)
    if run is None or bag.has_errors:
        return None
    ros2 = None
    if spec.ros2 is not None:  # imported only then: the ROS 2 types are not small
        from fmionnx.compile.ros2.settings import ros2_settings

        ros2 = ros2_settings(spec.ros2)
    system = CompiledSystem(
        name=spec.name,
        source=loaded.path,
        run=run,
        components=tuple(components),
        connections=tuple(usable),
        order=(
            execution_order_with_loops(components, usable, [loop.members for loop in loops])
            if loops
            else execution_order(components, usable)
        ),
        plots=plots,
        record=record,
        checks=checks,
        ros2=ros2,
        description=spec.description,
        inputs=inputs,
        loops=loops,
    )
    _whole_targets_warned(system, bag)
    with_inputs = _inputs_set(system, sources, bag)
    if with_inputs is None:
        return None
    system = with_inputs
    if ros2 is not None:
        # The ROS 2 section is checked like the rest of the file and its plan kept in the
        # system; the planner is only imported when a system has one (message definitions).
        from fmionnx.compile.ros2.plan import build_plan

        plan, found = build_plan(system, ros2.distro, sources)
        bag.extend(found)
        if plan is None or bag.has_errors:
            return None
        system = dataclasses.replace(system, ros2_plan=plan)
    return system


def _inputs_set(
    system: CompiledSystem, sources: SourceMap, bag: DiagnosticBag
) -> CompiledSystem | None:
    """The system with each system input's own ``value`` set on the ports it reaches, as
    ``--param NAME=value`` sets them (a bug hunt: a YAML input's value reached nothing). An
    SSP connector's bound value has reached them already along its connections: the same
    values again."""
    for system_input in system.inputs:
        if system_input.value is None or not system_input.targets:
            continue
        source = system_input.source or ValueSource.SYSTEM_FILE
        span = sources.value(("inputs", system_input.name, "value"))
        if not _set_once(system, system_input, span, bag):
            continue
        try:
            system = override_parameter(system, system_input.name, system_input.value, source, span)
        except OverrideError as exc:  # the command line's message, said of the file's input
            message = exc.worded(f"system input `{system_input.name}`", reaching="at")
            bag.emit(codes.PARAMETER_VALUE, message, span)
    return None if bag.has_errors else system


def _whole_targets_warned(system: CompiledSystem, bag: DiagnosticBag) -> None:
    """W031 at a system input whose transformation to an integer port has a factor or an
    offset that is not whole: only values it turns into whole numbers can be set (another
    is refused when set, naming the transformation; never rounded: docs/decisions.md)."""
    for system_input in system.inputs:
        for target in system_input.targets:
            dtype = target_dtype(system, target.ref)
            if dtype is None or not dtype.is_integer:
                continue
            if all(math.isfinite(n) and n.is_integer() for n in (target.factor, target.offset)):
                continue
            bag.emit(
                codes.LOSSY_CONVERSION,
                f"system input `{system_input.name}` reaches `{target.ref}` ({dtype}) "
                f"through {transformation_text(target)}: a value that does not become a whole "
                "number there is refused when it is set",
                system_input.span,
                hint="give the transformation a whole factor and offset, or set a float port",
            )


def _set_once(
    system: CompiledSystem, system_input: SystemInput, span: Span | None, bag: DiagnosticBag
) -> bool:
    """Whether no port the input's value reaches is set to another value in the file (E043
    at the value, a note at the other): which of two values written in one file wins is not
    for the user to guess (the review of this change). An SSP connector's bound value has
    set its ports already, to the same values."""
    by_name = {c.name: c for c in system.components}
    value = system_input.value
    once = True
    for target in system_input.targets:
        component = by_name.get(target.ref.component)
        parameters = () if component is None else component.parameters
        given = next((p for p in parameters if p.port == target.ref.port), None)
        if given is None or len(given.value) != 1 or value is None:
            continue
        try:
            item = transformed(value, target, target_dtype(system, target.ref))
        except OverrideError:
            continue  # refused when it is set, with the reason (E043 at the value)
        other = given.value[0]
        if other == item or _close(other, item):
            continue
        once = False
        notes = [Note("set here", given.span)] if given.span is not None else []
        bag.emit(
            codes.PARAMETER_VALUE,
            f"system input `{system_input.name}` sets `{target.ref}` to {item!r}, which "
            f"`components.{target.ref.component}.parameters` sets to {other!r}",
            span,
            hint="set it in one place: the input's `value`, or the component's parameter",
            notes=notes,
        )
    return once


def _close(a: object, b: object) -> bool:
    """Equal numbers but for rounding (a unit conversion computed on another path)."""
    return is_number(a) and is_number(b) and math.isclose(a, b, rel_tol=1e-12)


@dataclass(frozen=True, slots=True)
class _Transformation:
    """What a connection entry asks for beyond its ends: ``factor*x+offset`` and whether units
    are converted automatically (see :mod:`fmionnx.compile.unitcheck`)."""

    factor: float = 1.0
    offset: float = 0.0
    convert_units: bool = True


def _connection_texts(
    index: int,
    entry: str | ConnectionSpec,
    sources: SourceMap,
    lines: dict[Path, tuple[str, ...]] | None = None,
) -> tuple[str, Span, str, Span, _Transformation] | None:
    span = sources.value(("connections", index))
    if isinstance(entry, ConnectionSpec):
        return (
            entry.from_,
            sources.value(("connections", index, "from")),
            entry.to,
            sources.value(("connections", index, "to")),
            _Transformation(entry.factor, entry.offset, entry.convert_units),
        )
    parts = split_connection(entry)
    if parts is None:
        return None
    left, right = parts
    right_col = entry.find(right, entry.find("->")) if span.col else -1
    quoted = 1 if span.col and _starts_quoted(span, {} if lines is None else lines) else 0
    right_span = (
        Span(span.file, span.line, span.col + quoted + right_col) if right_col >= 0 else span
    )
    left_span = (
        Span(span.file, span.line, span.col + quoted + entry.find(left)) if span.col else span
    )
    return left, left_span, right, right_span, _Transformation()


def _starts_quoted(span: Span, cache: dict[Path, tuple[str, ...]]) -> bool:
    """Whether the entry at ``span`` starts with a quote (``cache``: each file's lines, looked
    up once per compile, not once per connection)."""
    lines = cache.get(span.file)
    if lines is None:
        lines = cache[span.file] = source_lines(span.file)
    if 0 < span.line <= len(lines):
        text = lines[span.line - 1]
        return span.col - 1 < len(text) and text[span.col - 1] in "'\""
    return False


def _connections(
    spec: SystemSpec,
    interfaces: dict[str, ComponentInterface | None],
    sources: SourceMap,
    bag: DiagnosticBag,
    mentioned: set[tuple[str, str]],
) -> list[Connection]:
    """Resolve and check every connection; ``mentioned`` collects every port named by one.

    Ports named by a connection that failed a check are "mentioned" too: warning that such
    an input is unconnected would only repeat the error.
    """
    result = []
    lines: dict[Path, tuple[str, ...]] = {}
    for index, entry in enumerate(spec.connections):
        span = sources.value(("connections", index))
        texts = _connection_texts(index, entry, sources, lines)
        if texts is None:
            bag.emit(
                codes.BAD_ENDPOINT,
                f"`{entry}` is not a connection",
                span,
                hint="write `source.port -> target.port`",
            )
            continue
        left, left_span, right, right_span, transformation = texts
        src = resolve_endpoint(left, left_span, interfaces, bag, role=Causality.OUTPUT)
        dst = resolve_endpoint(right, right_span, interfaces, bag, role=Causality.INPUT)
        for end in (src, dst):
            if end is not None:
                mentioned.add((end.ref.component, end.ref.port))
        for text in (left, right):
            parts = split_endpoint(text, interfaces)
            if parts is not None:
                mentioned.add((parts[0], ""))
        if src is None or dst is None:
            continue
        connection = _check_connection(src, dst, span, transformation, bag)
        if connection is not None:
            result.append(connection)
    return result


def _check_connection(
    src: ResolvedEndpoint,
    dst: ResolvedEndpoint,
    span: Span,
    transformation: _Transformation,
    bag: DiagnosticBag,
) -> Connection | None:
    if src.ref.component == dst.ref.component and src.ref.port == dst.ref.port:
        bag.emit(codes.SELF_CONNECTION, f"`{src.ref}` is connected to itself", span)
        return None
    if not check_causality(src, dst, span, bag):
        # A connection between the wrong ports is one mistake: its types and units would
        # only be compared for a connection that cannot exist.
        return None
    ok = check_dtype(src, dst, span, bag)
    size = check_count(src, dst, span, bag)
    # A connection that is wrong anyway gets its unit errors, but no notes about conversions.
    found = DiagnosticBag()
    transform = check_units(
        src,
        dst,
        span,
        found,
        factor=transformation.factor,
        offset=transformation.offset,
        convert=transformation.convert_units,
    )
    usable = ok and size is not None
    bag.extend(d for d in found if usable or d.severity is not Severity.INFO)
    if not usable or size is None or transform is None:
        return None
    return Connection(
        src.ref,
        dst.ref,
        src.port,
        dst.port,
        size,
        transform.factor,
        transform.offset,
        span,
        units=transform.units,
    )


def _covered(connection: Connection) -> set[int] | None:
    """Flat element indices written at the destination; None = the whole port."""
    if connection.dst.index is None:
        return None
    return {flat_index(connection.dst_port, connection.dst.index)}


def _check_drivers(connections: list[Connection], bag: DiagnosticBag) -> None:
    """E034 for each connection into an input (or element) an earlier one already drives,
    with a note at the earliest such connection. Linear: per input, the first connection of
    any kind, the first to the whole port and the first to each element are kept (a
    connection compared with every earlier one made 400 000 element connections hours)."""
    first_any: dict[tuple[str, str], tuple[int, Connection]] = {}
    first_whole: dict[tuple[str, str], tuple[int, Connection]] = {}
    first_at: dict[tuple[str, str], dict[int, tuple[int, Connection]]] = defaultdict(dict)
    for order, connection in enumerate(connections):
        key = (connection.dst.component, connection.dst.port)
        mine = _covered(connection)
        if mine is None:
            overlapping = [first_any.get(key)]
        else:
            at = first_at[key]
            overlapping = [first_whole.get(key), *(at.get(i) for i in mine)]
        found = [entry for entry in overlapping if entry is not None]
        if found:
            earlier = min(found, key=lambda entry: entry[0])[1]
            bag.emit(
                codes.MULTIPLE_DRIVERS,
                f"`{connection.dst}` is already driven by `{earlier.src}`",
                connection.span,
                hint="an input takes one driver; remove one of the connections",
                notes=[Note(f"first driven by `{earlier}`", earlier.span)],
            )
        first_any.setdefault(key, (order, connection))
        if mine is None:
            first_whole.setdefault(key, (order, connection))
        else:
            for index in mine:
                first_at[key].setdefault(index, (order, connection))


def _check_unconnected(
    components: list[Component],
    mentioned: set[tuple[str, str]],
    spec: SystemSpec,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> None:
    driven = mentioned
    for component in components:
        if component.external:
            continue
        explicit = {p.port for p in component.parameters}
        loose = [
            port
            for port in component.interface.with_causality(Causality.INPUT)
            if (component.name, port.name) not in driven and port.name not in explicit
        ]
        if loose:
            _warn_unconnected(component.name, loose, sources, bag)
    if len(spec.components) > 1:
        linked = {component for component, _ in mentioned}
        for component in components:
            if component.name not in linked:
                bag.emit(
                    codes.ISOLATED_COMPONENT,
                    f"component `{component.name}` has no connections",
                    sources.key(("components", component.name)),
                )


def _warn_unconnected(
    component: str, ports: list[Port], sources: SourceMap, bag: DiagnosticBag
) -> None:
    """One W030 per component, listing its unconnected inputs (issue #16).

    An FMU read for the first time often has several loose inputs; one warning per port
    buried the rest of the report (six four-line warnings for one ReadOdometry).
    """
    where = sources.key(("components", component))
    parameters = f"`components.{component}.parameters`"
    if len(ports) == 1:
        start = "its start value" if ports[0].start is not None else "zero"
        bag.emit(
            codes.UNCONNECTED_INPUT,
            f"input `{component}.{ports[0].name}` is not connected; {start} is used",
            where,
            hint=f"connect it, or set it under {parameters} to make the value explicit",
        )
        return
    names = ", ".join(f"`{port.name}`" for port in ports)
    zero = [f"`{port.name}`" for port in ports if port.start is None]
    if not zero:
        used = "their start values are used"
    elif len(zero) == len(ports):
        used = "zero is used for each"
    else:
        used = f"their start values are used (zero for {', '.join(zero)})"
    bag.emit(
        codes.UNCONNECTED_INPUT,
        f"{len(ports)} inputs of `{component}` are not connected: {names}; {used}",
        where,
        hint=f"connect them, or set them under {parameters} to make the values explicit",
    )
