"""Command-line overrides applied to a compiled system: a new stop time, parameter values,
kind settings (a signal's waveform numbers, a scene's values).

They act on the compiled system itself (never on the system file), so a node or a worker that
received a compiled system applies them the same way the CLI does.
"""

from __future__ import annotations

import dataclasses
import json
import math

from fmionnx.compile.ir import CompiledSystem, Origin, SystemInput
from fmionnx.core.diagnostics import Span, did_you_mean, one_of
from fmionnx.core.errors import FmionnxError, ModelError
from fmionnx.core.steps import count_problem, output_interval_problem, suggest_interval
from fmionnx.core.types import (
    Causality,
    Component,
    DType,
    ParameterValue,
    Scalar,
    ValueSource,
    is_number,
    is_whole_multiple,
    number_text,
)

#: Longest integer a ``--param`` value may have: far beyond uint64 (20 digits) and float64
#: (309 digits), and below Python's own limit of 4300.
MAX_INT_DIGITS = 400


class OverrideError(FmionnxError):
    """A command-line override (``--param``, ``--stop-time``) that does not fit the system."""


def override_stop(system: CompiledSystem, stop: float) -> CompiledSystem:
    """The system with another stop time (a whole number of base steps after the start)."""
    run = system.run
    if not math.isfinite(stop):
        msg = f"--stop-time {stop} must be a finite number of seconds"
        raise OverrideError(msg)
    if stop <= run.start:
        msg = f"--stop-time {stop} must be greater than the start time {run.start}"
        raise OverrideError(msg)
    problem = count_problem(stop - run.start, run.step, f"the run from {run.start} to {stop}")
    if problem is not None:
        msg = f"--stop-time {stop}: {problem}"
        raise OverrideError(msg)
    if is_whole_multiple(stop - run.start, run.step, rel=1e-6) is None:
        msg = (
            f"--stop-time {stop} is not a whole number of base steps ({run.step} s) after the start"
        )
        raise OverrideError(msg)
    origins = (*((k, o) for k, o in run.origins if k != "stop"), ("stop", Origin.COMMAND_LINE))
    return dataclasses.replace(system, run=dataclasses.replace(run, stop=stop, origins=origins))


def override_output_interval(system: CompiledSystem, interval: float) -> CompiledSystem:
    """The system writing a row every ``interval`` seconds (a whole multiple of the step)."""
    run = system.run
    problem = output_interval_problem(interval, run.step)
    if problem is not None:
        suggestion = suggest_interval(interval, run.step)
        msg = f"--output-interval {problem} (E047); use e.g. {suggestion:.12g}"
        raise OverrideError(msg)
    origins = (
        *((k, o) for k, o in run.origins if k != "output_interval"),
        ("output_interval", Origin.COMMAND_LINE),
    )
    return dataclasses.replace(
        system, run=dataclasses.replace(run, origins=origins, output_interval=interval)
    )


def _finite_float(text: str) -> float:
    """A JSON number as a float; one that overflows to infinity (``1e400``) is an error."""
    value = float(text)
    if math.isinf(value):
        msg = f"--param value `{_short(text)}` is beyond the range of a 64-bit float"
        raise OverrideError(msg)
    return value


def _bounded_int(text: str) -> int:
    """A JSON integer; one beyond any numeric type (and Python's digit limit) is an error."""
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        msg = f"--param value `{_short(text)}` has more than {MAX_INT_DIGITS} digits"
        raise OverrideError(msg)
    return int(text)


def _short(text: str) -> str:
    return text if len(text) <= 24 else f"{text[:12]}...{text[-6:]} ({len(text)} characters)"


def parse_value(text: str) -> Scalar | list[Scalar]:
    """A command-line value: JSON (``1.5``, ``true``, ``[1, 2]``), else the plain string.

    Numbers are range-checked while parsing (OverrideError): JSON reads ``1e400`` as infinity
    and refuses integers of more than 4300 digits with a bare ValueError.
    """
    try:
        value = json.loads(text, parse_float=_finite_float, parse_int=_bounded_int)
    except json.JSONDecodeError:
        return text
    if isinstance(value, list) and all(isinstance(v, bool | int | float | str) for v in value):
        return value
    if isinstance(value, bool | int | float | str):
        return value
    return text


def _coerce(dtype: DType, value: Scalar) -> Scalar | None:
    if dtype is DType.BOOL:
        return value if isinstance(value, bool) else None
    if dtype.is_integer:
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    if dtype.is_float:
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        return float(value) if ok else None
    return value if isinstance(value, str) else None


def override_parameter(
    system: CompiledSystem,
    key: str,
    value: Scalar | list[Scalar],
    source: ValueSource = ValueSource.COMMAND_LINE,
    span: Span | None = None,
) -> CompiledSystem:
    """The system with ``component.name = value`` set before initialization.

    ``key`` may also name a system input (``inputs:``, an SSP system's open connector):
    then every port it reaches gets the value through its own transformation. A one-model
    system also accepts the bare variable name (``--param k=2``).
    """
    for system_input in system.inputs:
        if system_input.name == key:
            return _override_input(system, system_input, value, source, span)
    return _override_port(system, key, value, source, span)


def _override_input(
    system: CompiledSystem,
    system_input: SystemInput,
    value: Scalar | list[Scalar],
    source: ValueSource,
    span: Span | None = None,
) -> CompiledSystem:
    key = system_input.name
    if isinstance(value, list):
        msg = f"--param `{key}`: a system input takes one value, got `{value}`"
        raise OverrideError(msg)
    given = dataclasses.replace(system_input, value=value, source=source)
    system = dataclasses.replace(
        system, inputs=tuple(given if i is system_input else i for i in system.inputs)
    )
    for target in system_input.targets:
        item: Scalar = value
        if target.factor != 1.0 or target.offset != 0.0:
            if not is_number(value):
                msg = (
                    f"--param `{key}`: `{value}` reaches `{target.ref}` through a linear "
                    "transformation and must be a number"
                )
                raise OverrideError(msg)
            item = target.factor * value + target.offset
            if math.isinf(item):
                msg = f"--param `{key}`: {number_text(value)} becomes infinite at `{target.ref}`"
                raise OverrideError(msg)
        try:
            system = _override_port(system, str(target.ref), item, source, span)
        except OverrideError as exc:
            detail = str(exc).split(": ", 1)[-1]  # without the target's own `--param` prefix
            msg = f"--param `{key}` (a system input, reaching `{target.ref}`): {detail}"
            raise OverrideError(msg) from exc
    return system


def _override_port(
    system: CompiledSystem,
    key: str,
    value: Scalar | list[Scalar],
    source: ValueSource,
    span: Span | None = None,
) -> CompiledSystem:
    names = [c.name for c in system.components]
    owners = [n for n in names if key.startswith(n + ".")]
    if owners:
        component_name = max(owners, key=len)
        port_name = key[len(component_name) + 1 :]
    elif len(names) == 1:
        component_name, port_name = names[0], key  # a lone model: plain variable names
    elif "." not in key:
        inputs = [i.name for i in system.inputs]
        also = f"; system inputs: {', '.join(inputs)}" if inputs else ""
        msg = (
            f"--param `{key}`: expected `component.name=value` (components: {', '.join(names)}"
            f"{also})"
        )
        raise OverrideError(msg)
    else:
        guess = key.split(".", 1)[0]
        hint = did_you_mean(guess, names) or one_of(names)
        msg = f"--param `{key}`: no component `{guess}`; {hint}"
        raise OverrideError(msg)
    component = system.component(component_name)
    settable = [
        p.name
        for p in component.interface.ports
        if p.causality in (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER, Causality.INPUT)
    ]
    port = component.interface.port(port_name)
    if port is None or port.name not in settable:
        settings = kind_settings(component)
        if port_name in settings:
            return _override_setting(system, component, port_name, value, key)
        known = [*settable, *settings]
        hint = did_you_mean(port_name, known) or one_of(known)
        what = "parameter or setting" if settings else "parameter"
        msg = f"--param `{key}`: `{component_name}` has no {what} `{port_name}`; {hint}"
        raise OverrideError(msg)
    flat = value if isinstance(value, list) else [value]
    size = 1 if port.size is None else port.size  # None: known at run time, one value
    for item in flat:  # before coercing: float() of a huge integer raises OverflowError
        problem = port.dtype.out_of_range(item) or port.bounds_problem(item)
        if problem is not None:
            msg = f"--param `{key}`: {number_text(item)} {problem}"
            raise OverrideError(msg)
    coerced = [_coerce(port.dtype, v) for v in flat]
    if len(flat) != size or any(c is None for c in coerced):
        msg = (
            f"--param `{key}`: expected {size} value(s) of type {port.dtype} "
            f"(shape {port.shape_text()}), got `{value}`"
        )
        raise OverrideError(msg)
    values = tuple(c for c in coerced if c is not None)
    kept = tuple(p for p in component.parameters if p.port != port_name)
    updated = dataclasses.replace(
        component, parameters=(*kept, ParameterValue(port_name, values, span, source))
    )
    components = tuple(updated if c.name == component_name else c for c in system.components)
    return dataclasses.replace(system, components=components)


def kind_settings(component: Component) -> tuple[str, ...]:
    """The settings of ``component``'s kind (a signal's waveform numbers, a scene's values),
    or none when the kind has none or its model cannot be read (the compiler reported it)."""
    from fmionnx.kinds.base import Settable
    from fmionnx.kinds.registry import COMPONENT_KINDS

    kind = COMPONENT_KINDS.get(component.kind)
    if not isinstance(kind, Settable):
        return ()
    try:
        return kind.settings(component)
    except ModelError:
        return ()


def apply_component_setting(
    system: CompiledSystem, component: Component, name: str, value: Scalar | tuple[Scalar, ...]
) -> CompiledSystem:
    """``system`` with ``component``'s kind setting ``name`` at ``value``: its config replaced by
    the kind's :meth:`~fmionnx.kinds.base.Settable.with_setting` (SettingError when the kind
    refuses it). A study's cases and ``--param`` go through here alike."""
    from fmionnx.kinds.base import Settable, SettingError
    from fmionnx.kinds.registry import COMPONENT_KINDS

    kind = COMPONENT_KINDS[component.kind]
    if not isinstance(kind, Settable):
        raise SettingError(f"`{component.name}` has no settings a study can vary")
    config = kind.with_setting(component, name, value)
    updated = dataclasses.replace(component, config=config)
    components = tuple(updated if c.name == component.name else c for c in system.components)
    return dataclasses.replace(system, components=components)


def _override_setting(
    system: CompiledSystem,
    component: Component,
    name: str,
    value: Scalar | list[Scalar],
    key: str,
) -> CompiledSystem:
    from fmionnx.kinds.base import SettingError

    try:
        return apply_component_setting(
            system, component, name, tuple(value) if isinstance(value, list) else value
        )
    except SettingError as exc:
        raise OverrideError(f"--param `{key}`: {exc}") from exc
