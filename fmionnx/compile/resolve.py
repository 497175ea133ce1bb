"""Resolve components: read each model's interface, check parameters, periods, run settings."""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path

from fmionnx.compile.ir import Origin, RunSettings
from fmionnx.compile.typecheck import declared_note
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span, did_you_mean, one_of
from fmionnx.core.errors import ModelError
from fmionnx.core.porttotal import check_port_total
from fmionnx.core.specbase import ComponentSpecBase, ParameterLiteral
from fmionnx.core.steps import (
    MAX_RUN_STEPS,
    WARN_STEPS,
    count_problem,
    default_step,
    output_interval_problem,
    step_problem,
    suggest_interval,
)
from fmionnx.core.types import (
    Causality,
    ComponentInterface,
    DType,
    ParameterValue,
    Port,
    Scalar,
    is_hex_bytes,
    is_whole_multiple,
    number_text,
)
from fmionnx.core.units import Unit, conversion
from fmionnx.kinds.base import fixed_size_problem
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.runspec import RunSpec
from fmionnx.spec.sourcemap import SourceMap

#: Variables whose value a system file may set before initialization.
SETTABLE = (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER, Causality.INPUT)


def model_path(base: Path, text: str) -> Path:
    """A component path relative to the system file's folder (absolute paths kept; ``~`` and
    ``~user`` expanded when there is such a home folder)."""
    path = Path(text)
    with contextlib.suppress(RuntimeError):  # `~name` of no user: kept as written (E010)
        path = path.expanduser()
    return path if path.is_absolute() else base / path


def entry_path(system: Path, spec: ComponentSpecBase) -> Path:
    """The model file of a component entry of the system file ``system``.

    An entry without a model file (a kind that lets ``path`` be omitted) is defined by the
    system file itself, so that file is its path: messages and ``graph`` then name the file
    the definition is in, and no code needs a "no path" case.
    """
    return model_path(system.parent, spec.path) if spec.has_model_file else system


def _unreadable(path: Path, exc: OSError) -> str:
    """The file an OSError of reading the model at ``path`` is about: the model, or a file
    it names (an include of a scene), which is then said so -- never the model itself when
    the model exists and another file is missing."""
    named = exc.filename
    if not isinstance(named, str | bytes):
        return f"`{path}`"
    other = os.fsdecode(named)
    if Path(other).absolute() == path.absolute():
        return f"`{path}`"
    return f"`{other}` (a file `{path}` needs)"


def read_interface(
    name: str,
    spec: ComponentSpecBase,
    system: Path,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> ComponentInterface | None:
    """Read a component's interface; a ModelError becomes a diagnostic at its ``path``.

    ``system`` is the system file the entry is in (paths are relative to its folder).
    """
    kind = COMPONENT_KINDS[spec.kind]
    path = entry_path(system, spec)
    span = sources.value(("components", name, "path"))
    try:
        interface = kind.read_interface(path, spec)
        check_port_total(interface)
    except ModelError as exc:
        bag.emit(exc.code, f"component `{name}`: {exc}", span, hint=exc.hint)
        return None
    except OSError as exc:  # a name too long, a loop of links: the file cannot be looked at
        bag.emit(
            codes.FILE_NOT_FOUND,
            f"component `{name}`: {_unreadable(path, exc)} cannot be read: "
            + (exc.strerror or str(exc)),
            span,
        )
        return None
    for problem in kind.check(spec, interface):
        where = sources.value(("components", name, problem.key))
        bag.emit(problem.code, f"component `{name}`: {problem.message}", where, hint=problem.hint)
    return interface


def _flatten(value: ParameterLiteral) -> list[Scalar] | None:
    if isinstance(value, list):
        flat: list[Scalar] = []
        for item in value:
            inner = _flatten(item)
            if inner is None:
                return None
            flat.extend(inner)
        return flat
    return [value]


def _fits(dtype: DType, value: Scalar) -> bool:
    if dtype is DType.BOOL:
        return isinstance(value, bool)
    if dtype.is_integer:
        return isinstance(value, int) and not isinstance(value, bool)
    if dtype.is_float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if dtype is DType.STRING:
        return isinstance(value, str)
    if dtype is DType.BINARY:  # hexadecimal text, as FMI 3 writes binary start values
        return isinstance(value, str) and is_hex_bytes(value)
    return False


def resolve_parameters(
    name: str,
    spec: ComponentSpecBase,
    interface: ComponentInterface,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[ParameterValue, ...]:
    """Check every ``parameters:`` entry against the interface; return the valid ones."""
    settable = [p.name for p in interface.ports if p.causality in SETTABLE]
    resolved = []
    for key, value in spec.parameters.items():
        span = sources.key(("components", name, "parameters", key))
        port = interface.port(key)
        if port is None:
            hint = did_you_mean(key, settable) or one_of(settable)
            bag.emit(
                codes.UNKNOWN_PARAMETER,
                f"component `{name}` has no parameter or input `{key}`",
                span,
                hint=hint,
            )
            continue
        if port.causality not in SETTABLE:
            bag.emit(
                codes.PARAMETER_CAUSALITY,
                f"`{name}.{key}` is an {port.causality.value} and cannot be set"
                if port.causality.value[0] in "aeiou"
                else f"`{name}.{key}` is a {port.causality.value} and cannot be set",
                span,
                hint="only parameters and inputs (start values) can be set",
                notes=declared_note(port),
            )
            continue
        flat = _flatten(value)
        value_span = sources.value(("components", name, "parameters", key))
        written_in = sources.units.get(("components", name, "parameters", key))
        if flat is not None and written_in is not None:
            flat = _in_port_unit(name, port, flat, written_in, value_span, bag)
        if flat is None or not _check_value(name, port, flat, value_span, bag):
            continue
        problem = fixed_size_problem(COMPONENT_KINDS[spec.kind], interface, port, tuple(flat))
        if problem is not None:  # the ports it sizes were compiled with its start value
            bag.emit(
                codes.PARAMETER_VALUE,
                f"`{name}.{key}`: {problem}",
                value_span,
                notes=declared_note(port),
            )
            continue
        source = sources.value_source(("components", name, "parameters", key))
        resolved.append(ParameterValue(key, _as_port_numbers(port, flat), value_span, source))
    return tuple(resolved)


def _as_port_numbers(port: Port, flat: list[Scalar]) -> tuple[Scalar, ...]:
    """``flat`` as the port holds it: a whole number written for a float port is that float
    (``k: 3`` is 3.0), as ``--param`` gives it, so a system's compiled form does not depend on
    how a value was spelled (an SSP round trip wrote ``3`` back as ``3.0``: another hash)."""
    if not port.dtype.is_float:
        return tuple(flat)
    return tuple(
        float(v) if isinstance(v, int) and not isinstance(v, bool) and abs(v) < 2**1023 else v
        for v in flat
    )


def _in_port_unit(
    name: str, port: Port, flat: list[Scalar], unit: Unit, span: Span, bag: DiagnosticBag
) -> list[Scalar] | None:
    """Values written in ``unit`` (an SSV value's ``unit``) converted to the port's unit.

    SSP 2.0 (SSV, ``ssv:Real unit``): the value is in the unit named, defined in the set's
    ``ssv:Units``. A port whose unit has the same definition takes the number as it is; one
    of the same quantity gets it converted (``500 mH`` -> ``0.5`` for a port in ``H``); a
    port of another quantity is E033. A port without a unit definition cannot be checked:
    the number is used as written when the names agree, else W070 says so.
    """
    target = port.unit_definition
    if target is None:
        if port.unit != unit.name:
            bag.emit(
                codes.SSP_IGNORED,
                f"`{name}.{port.name}` is given in `{unit.name}`, but the model defines no unit "
                f"for it (`{port.unit or ''}`); the value is used as written",
                span,
            )
        return flat
    if not unit.same_dimension(target):
        bag.emit(
            codes.UNIT,
            f"`{name}.{port.name}` is given in `{unit.name}` ({unit.dimension()}), but the "
            f"model measures it in `{target.name}` ({target.dimension()})",
            span,
            notes=declared_note(port),
        )
        return None
    change = conversion(unit, target, relative=port.relative_quantity)
    if change.is_identity:
        return flat
    return [
        change.factor * v + change.offset
        if isinstance(v, int | float) and not isinstance(v, bool)
        else v
        for v in flat
    ]


def _check_value(
    name: str, port: Port, flat: list[Scalar], span: object, bag: DiagnosticBag
) -> bool:
    from fmionnx.core.diagnostics import Span

    assert isinstance(span, Span)
    size = port.size
    if size is not None and len(flat) != size:
        bag.emit(
            codes.PARAMETER_VALUE,
            f"`{name}.{port.name}` has shape {port.shape_text()} ({size} element"
            f"{'s' if size != 1 else ''}) but {len(flat)} value{'s are' if len(flat) != 1 else ' is'} given",
            span,
            notes=declared_note(port),
        )
        return False
    bad = [v for v in flat if not _fits(port.dtype, v)]
    if bad:
        bag.emit(
            codes.PARAMETER_VALUE,
            f"`{name}.{port.name}` is of type {port.dtype}; {bad[0]!r} does not fit",
            span,
            hint="write true/false for booleans and whole numbers for integers"
            if port.dtype is DType.BOOL or port.dtype.is_integer
            else "write a binary value as hexadecimal text, e.g. `0c0d`"
            if port.dtype is DType.BINARY
            else None,
            notes=declared_note(port),
        )
        return False
    for value in flat:
        problem = port.dtype.out_of_range(value) or port.bounds_problem(value)
        if problem is not None:
            bag.emit(
                codes.PARAMETER_VALUE,
                f"`{name}.{port.name}`: {number_text(value)} {problem}",
                span,
                notes=declared_note(port),
            )
            return False
    return True


def resolve_run(
    run: RunSpec,
    interfaces: dict[str, ComponentInterface],
    periods: dict[str, float],
    sources: SourceMap,
    bag: DiagnosticBag,
    *,
    fallback_step: bool = False,
) -> RunSettings | None:
    """Resolve start/stop/step, recording where each value came from; never guess silently.

    ``fallback_step`` (an SSP file, whose format has no step): when nothing gives a step, the
    built-in :func:`default_step` of the run's length is used, and recorded as such.
    """
    origins: list[tuple[str, Origin]] = [("start", Origin.SYSTEM_FILE)]
    experiments = [i.default_experiment for i in interfaces.values() if i.default_experiment]
    stop = run.stop
    if stop is not None:
        origins.append(("stop", Origin.SYSTEM_FILE))
    else:
        stops = {e.stop for e in experiments if e.stop is not None}
        if len(stops) == 1:
            stop = stops.pop()
            origins.append(("stop", Origin.MODEL_DEFAULT))
        else:
            bag.emit(
                codes.MISSING_KEY,
                "missing `run.stop`: no single model default experiment gives a stop time",
                sources.key(("run",)),
                hint="add `run: {stop: 10, step: 0.01}`",
            )
            return None
    step = run.step
    if step is not None:
        origins.append(("step", Origin.SYSTEM_FILE))
    elif periods:
        step = min(periods.values())
        origins.append(("step", Origin.SYSTEM_FILE))
    else:
        steps = sorted(e.step for e in experiments if e.step is not None)
        if steps:
            step = steps[0]
            origins.append(("step", Origin.MODEL_DEFAULT))
        elif fallback_step and math.isfinite(stop - run.start) and stop > run.start:
            step = default_step(stop - run.start)
            origins.append(("step", Origin.BUILTIN_DEFAULT))
        else:
            bag.emit(
                codes.MISSING_KEY,
                "missing `run.step`: no component period or model default experiment gives one",
                sources.key(("run",)),
                hint="add `step:` under `run:` (seconds between two communication points)",
            )
            return None
    problem = step_problem(step)
    if problem is not None:  # a model's default step; the system file's is checked on load
        bag.emit(codes.RUN_SETTINGS, f"the base step {problem}", sources.value(("run", "step")))
        return None
    if stop <= run.start:
        bag.emit(
            codes.RUN_SETTINGS,
            f"`run.stop` ({stop}) must be greater than `run.start` ({run.start})",
            sources.value(("run", "stop")),
        )
        return None
    what = f"the run from {run.start} to {stop}"
    problem = count_problem(stop - run.start, step, what)
    if problem is not None:
        key = "stop" if not math.isfinite(stop - run.start) else "step"
        bag.emit(
            codes.RUN_SETTINGS,
            problem,
            sources.value(("run", key)),
            hint="use a shorter run or a longer step",
        )
        return None
    if is_whole_multiple(stop - run.start, step, rel=1e-6) is None:
        bag.emit(
            codes.RUN_SETTINGS,
            f"the run from {run.start} to {stop} is not a whole number of steps of {step}",
            sources.value(("run", "step")),
            hint="choose a step that divides the run length",
        )
        return None
    interval = run.output_interval
    if interval is not None:
        problem = output_interval_problem(interval, step)
        if problem is not None:
            bag.emit(
                codes.OUTPUT_INTERVAL,
                f"`run.output_interval` {problem}",
                sources.value(("run", "output_interval")),
                hint="use a whole multiple of the step, e.g. "
                f"{suggest_interval(interval, step):.12g}",
            )
            return None
        origins.append(("output_interval", Origin.SYSTEM_FILE))
    settings = RunSettings(run.start, stop, step, tuple(origins), interval)
    if settings.steps > WARN_STEPS:
        bag.emit(
            codes.LONG_RUN,
            f"the run is {settings.steps:.3g} base steps of {step} s (more than "
            f"{WARN_STEPS:.0e}); it may take hours",
            sources.value(("run", "step")),
            hint=f"check `run.stop` and `run.step`; `fmionnx run` refuses more than "
            f"{MAX_RUN_STEPS:.0e} steps unless `--max-steps` allows them",
        )
    return settings
