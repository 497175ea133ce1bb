"""Command-line overrides applied to a compiled system: a new stop time, parameter values,
kind settings (a signal's waveform numbers, a scene's values).

They act on the compiled system itself (never on the system file), so a node or a worker that
received a compiled system applies them the same way the CLI does.
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
from typing import cast

from fmionnx.compile.ir import CompiledSystem, InputTarget, Origin, SystemInput
from fmionnx.core.diagnostics import Span, did_you_mean, one_of
from fmionnx.core.errors import FmionnxError, ModelError
from fmionnx.core.steps import count_problem, output_interval_problem, suggest_interval
from fmionnx.core.types import (
    Causality,
    Component,
    DType,
    ParameterValue,
    Port,
    PortRef,
    Scalar,
    ValueSource,
    is_hex_bytes,
    is_number,
    is_whole_multiple,
    number_text,
)

#: Longest integer a ``--param`` value may have: far beyond uint64 (20 digits) and float64
#: (309 digits), and below Python's own limit of 4300.
MAX_INT_DIGITS = 400


class OverrideError(FmionnxError):
    """A command-line override (``--param``, ``--stop-time``) that does not fit the system.

    Its message is built from parts, so that another wording can be built from the same
    parts rather than by taking the text apart (a system input's own ``value`` is said as
    ``system input `NAME```, not ``--param `NAME```): ``detail`` says what is wrong,
    ``subject`` names what was given (``--param `k```; None: ``detail`` is the whole
    message), ``reached`` the port a system input's value was refused at.
    """

    def __init__(
        self, detail: str, *, subject: str | None = None, reached: PortRef | None = None
    ) -> None:
        self.detail = detail
        self.subject = subject
        self.reached = reached
        super().__init__(detail if subject is None else self.worded(subject))

    def worded(self, subject: str, reaching: str = "a system input, reaching") -> str:
        """The message about ``subject``: ``SUBJECT (REACHING `port`): DETAIL``."""
        where = "" if self.reached is None else f" ({reaching} `{self.reached}`)"
        return f"{subject}{where}: {self.detail}"


def _param(key: str) -> str:
    """How the command line names a ``--param`` (an error's subject)."""
    return f"--param `{key}`"


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


def plain_value(value: object) -> object:
    """``value`` as the plain Python values an override is checked against: a numpy number
    (``np.int64(2)``, an element of ``np.arange``) or another ``numbers.Real`` as the int or
    float it is, a numpy bool as a bool (never a number), a tuple or a numpy array as a list.

    A Python caller's values come from numpy more often than not; without this they were
    refused as if of the wrong type (a bug hunt: ``expected 1 value(s) of type float64, got
    `2```). Anything else is returned as it is, for the type checks to name.
    """
    if isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, list | tuple):
        return [plain_value(item) for item in value]
    if type(value).__module__ == "numpy" and hasattr(value, "tolist"):
        return plain_value(value.tolist())  # np.generic: a Python scalar; an array: a list
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    return value


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
    system also accepts the bare variable name (``--param k=2``). A numpy value or a tuple
    is taken as the plain value it holds (:func:`plain_value`).
    """
    # A caller's numpy values too; what is none of Scalar's types is refused further on.
    value = cast("Scalar | list[Scalar]", plain_value(value))
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
        detail = f"a system input takes one value, got `{value}`"
        raise OverrideError(detail, subject=_param(key))
    given = dataclasses.replace(system_input, value=value, source=source)
    system = dataclasses.replace(
        system, inputs=tuple(given if i is system_input else i for i in system.inputs)
    )
    for target in system_input.targets:
        try:
            item = transformed(value, target, target_dtype(system, target.ref))
        except OverrideError as exc:
            raise OverrideError(exc.detail, subject=_param(key)) from exc
        try:
            system = _override_port(system, str(target.ref), item, source, span)
        except OverrideError as exc:  # said of the input, at the port it reached
            raise OverrideError(exc.detail, subject=_param(key), reached=target.ref) from exc
    return system


def target_dtype(system: CompiledSystem, ref: PortRef) -> DType | None:
    """The type of the port at ``ref`` (None: no such port; the compiler said so)."""
    component = next((c for c in system.components if c.name == ref.component), None)
    port = None if component is None else component.interface.port(ref.port)
    return None if port is None else port.dtype


def transformed(value: Scalar, target: InputTarget, dtype: DType | None) -> Scalar:
    """What a system input's ``value`` sets on ``target``: ``factor*value + offset`` (the
    value itself without a transformation); OverrideError says why it cannot be.

    The arithmetic is a float's, but an integer port takes a whole result as the integer
    (``2*3 + 1`` sets 7, where 7.0 was refused as not an integer: a bug hunt found such an
    input could never be set); a result that is not whole is refused naming the
    transformation, never rounded (docs/decisions.md).
    """
    factor, offset = target.factor, target.offset
    if factor == 1.0 and offset == 0.0:
        return value
    if not is_number(value):
        detail = (
            f"`{value}` reaches `{target.ref}` through a linear transformation and must be a number"
        )
        raise OverrideError(detail)
    integer = dtype is not None and dtype.is_integer
    if integer and isinstance(value, int) and _whole(factor) and _whole(offset):
        return int(factor) * value + int(offset)  # exact: no 64-bit integer rounded to 53 bits
    item = factor * value + offset
    if math.isinf(item):
        raise OverrideError(f"{number_text(value)} becomes infinite at `{target.ref}`")
    if not integer:
        return item
    if not item.is_integer():
        detail = (
            f"{number_text(value)} becomes {number_text(item)} at `{target.ref}` "
            f"({transformation_text(target)}), which takes whole numbers ({dtype})"
        )
        raise OverrideError(detail)
    return int(item)


def transformation_text(target: InputTarget) -> str:
    """``factor 2, offset 1``: a target's transformation as the system file writes it."""
    return f"factor {_short_number(target.factor)}, offset {_short_number(target.offset)}"


def _whole(number: float) -> bool:
    return math.isfinite(number) and number.is_integer()


def _short_number(number: float) -> str:
    """``2`` for a whole float (as the file wrote it), else its repr."""
    return repr(int(number)) if _whole(number) and abs(number) < 2**53 else repr(number)


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
        detail = f"expected `component.name=value` (components: {', '.join(names)}{also})"
        raise OverrideError(detail, subject=_param(key))
    else:
        guess = key.split(".", 1)[0]
        hint = did_you_mean(guess, names) or one_of(names)
        raise OverrideError(f"no component `{guess}`; {hint}", subject=_param(key))
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
        detail = f"`{component_name}` has no {what} `{port_name}`; {hint}"
        raise OverrideError(detail, subject=_param(key))
    flat = value if isinstance(value, list) else [value]
    if port.dtype in TEXT_DTYPES:
        flat = [_as_text(item, source) for item in flat]
    size = 1 if port.size is None else port.size  # None: known at run time, one value
    for item in flat:  # before coercing: float() of a huge integer raises OverflowError
        problem = port.dtype.out_of_range(item) or port.bounds_problem(item)
        if problem is not None:
            raise OverrideError(f"{number_text(item)} {problem}", subject=_param(key))
    coerced = [_coerce(port.dtype, v) for v in flat]
    if len(flat) != size or any(c is None for c in coerced):
        detail = (
            f"expected {size} value(s) of type {port.dtype} (shape {port.shape_text()}), "
            f"got `{value}`{_text_hint(port.dtype)}"
        )
        if port.size is None and len(flat) != 1:  # its size is known only once fed
            detail += (
                "; a port of symbolic shape takes one value here, set on every element "
                "(an array for a single ONNX model: `--input NAME=file.npy`)"
            )
        raise OverrideError(detail, subject=_param(key))
    values = tuple(c for c in coerced if c is not None)
    problem = _binary_problem(port, values) or _size_problem(component, port, values)
    if problem is not None:
        raise OverrideError(problem, subject=_param(key))
    kept = tuple(p for p in component.parameters if p.port != port_name)
    updated = dataclasses.replace(
        component, parameters=(*kept, ParameterValue(port_name, values, span, source))
    )
    components = tuple(updated if c.name == component_name else c for c in system.components)
    return dataclasses.replace(system, components=components)


#: Types whose values are text: a String's characters, a Binary's hexadecimal bytes.
TEXT_DTYPES = (DType.STRING, DType.BINARY)


def _as_text(item: object, source: ValueSource) -> Scalar:
    """A value for a String or Binary port as the text it sets.

    A command-line value is read as JSON before its port is known, so ``-p label=12`` and
    ``-p blob=1234`` arrive as numbers: a whole number (or ``true``) is taken as the text it
    was written as, which JSON keeps exactly (no leading zeros, no other spelling). A
    fraction or an exponent is not (``1.50`` reads as 1.5), so it is left for the type check
    to refuse with a hint to quote it; so is a number from a file, whose YAML reading has
    lost the text already (``0012`` is 12). A Python caller's ``bytes`` are a Binary's hex.
    """
    if isinstance(item, bytes | bytearray):
        return item.hex()
    if source is not ValueSource.COMMAND_LINE or not isinstance(item, int):
        return cast("Scalar", item)  # as given: the type check names what does not fit
    return json.dumps(item)  # 12 -> "12", True -> "true"


def _text_hint(dtype: DType) -> str:
    """What to write instead of a value a String or Binary port refused (its type's)."""
    if dtype is DType.BINARY:
        return '; binary is hexadecimal text (`0c0d`); quote hex that reads as a number (`"1e00"`)'
    if dtype is DType.STRING:
        return '; quote text that reads as a number (`"1.50"`)'
    return ""


def _binary_problem(port: Port, values: tuple[Scalar, ...]) -> str | None:
    """Text a Binary port cannot take: it must be hexadecimal, two digits per byte, as FMI 3
    writes binary start values; refused here rather than as a fault when the run sets it."""
    if port.dtype is not DType.BINARY:
        return None
    for text in values:
        if not is_hex_bytes(str(text)):
            return (
                f"`{_short(str(text))}` is not hexadecimal text of whole bytes: binary "
                f"`{port.name}` takes two hex digits per byte, e.g. `0c0d`"
            )
    return None


def _size_problem(component: Component, port: Port, values: tuple[Scalar, ...]) -> str | None:
    """Why ``values`` would resize ports of ``component`` (:func:`fixed_size_problem`)."""
    from fmionnx.kinds.base import fixed_size_problem
    from fmionnx.kinds.registry import COMPONENT_KINDS

    kind = COMPONENT_KINDS.get(component.kind)
    return fixed_size_problem(kind, component.interface, port, values)


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
        raise OverrideError(str(exc), subject=_param(key)) from exc
