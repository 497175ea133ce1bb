"""Resolve the system's named inputs (``inputs:``) to the settable ports they reach.

A system input is a name for a value that nothing inside the system computes: an SSP
system's open ``input`` or ``parameter`` connector, or a YAML file's ``inputs:`` entry. It is
checked here like a ``parameters:`` entry, so that ``fmionnx run --param NAME=value`` later
only has to compute and set values: every target must be a parameter or an input of one
element (an FMU variable), since one value is set on each.

A system input is set once, before initialization, never during the run, so it may reach a
string or binary port (an SSP string parameter connector does), which no connection can
(:data:`~fmionnx.compile.typecheck.UNCONNECTABLE`). What such a target cannot have is a
linear transformation (only numbers are transformed: no value could ever be set) or, for a
binary port, a ``value`` that is not hexadecimal text (the run ended in a fault at t=0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fmionnx.compile.endpoints import resolve_endpoint
from fmionnx.compile.ir import InputTarget, SystemInput
from fmionnx.compile.overrides import transformation_text
from fmionnx.compile.resolve import SETTABLE
from fmionnx.compile.typecheck import declared_note
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.types import ComponentInterface, DType, Port, Scalar, is_hex_bytes
from fmionnx.spec.model import InputTargetSpec, SystemSpec
from fmionnx.spec.sourcemap import SourceMap


def compile_inputs(
    spec: SystemSpec,
    interfaces: Mapping[str, ComponentInterface | None],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[SystemInput, ...]:
    """Every ``inputs:`` entry with its targets resolved; problems (E020-E023, E031, E043,
    E044) in ``bag``."""
    result = []
    for name, entry in spec.inputs.items():
        targets = []
        binary = []
        floats = []  # whether each target is a float port
        for index, item in enumerate(entry.to):
            target = item if isinstance(item, InputTargetSpec) else InputTargetSpec(to=item)
            span = sources.value(("inputs", name, "to", index))
            resolved = resolve_endpoint(target.to, span, interfaces, bag)
            if resolved is None:
                continue
            port, ref = resolved.port, resolved.ref
            if port.causality not in SETTABLE:
                bag.emit(
                    codes.PARAMETER_CAUSALITY,
                    f"system input `{name}` reaches `{ref}`, a {port.causality.value}, which "
                    "cannot be set",
                    span,
                    hint="only parameters and inputs (start values) can be set",
                    notes=declared_note(port),
                )
                continue
            if ref.index is not None or port.size not in (1, None):  # None: known at run time
                bag.emit(
                    codes.PARAMETER_CAUSALITY,
                    f"system input `{name}` reaches `{ref}`: a system input sets one value on "
                    "a port of one element",
                    span,
                    hint="set array ports with `--param component.port=[...]`",
                    notes=declared_note(port),
                )
                continue
            reached = InputTarget(ref, target.factor, target.offset)
            # Kept when refused: the port is set from outside all the same (no W030 besides).
            targets.append(reached)
            floats.append(port.dtype.is_float)
            if _transformable(name, reached, port, span, bag) and port.dtype is DType.BINARY:
                binary.append(reached)
        value = entry.value
        if floats and all(floats) and type(value) is int and abs(value) < 2**1023:  # 3 -> 3.0
            value = float(value)  # on Real ports, as `parameters:` gives it (SSP round trip)
        if binary:
            _check_hexadecimal(name, value, binary, sources, bag)
        if isinstance(value, float) and math.isnan(value):  # reaching no port, it was kept
            bag.emit(
                codes.PARAMETER_VALUE,
                f"system input `{name}`: nan is not a number (NaN); a value is a number (an "
                "infinity is allowed), a boolean or a string",
                sources.value(("inputs", name, "value")),
            )
            continue
        source = sources.value_source(("inputs", name, "value")) if value is not None else None
        result.append(
            SystemInput(name, tuple(targets), sources.key(("inputs", name)), value, source)
        )
    return tuple(result)


def _transformable(
    name: str, target: InputTarget, port: Port, span: Span | None, bag: DiagnosticBag
) -> bool:
    """Whether ``target``'s transformation, if any, can give its port a value (E031 if not).

    ``factor*value + offset`` is a number, and a string or binary port takes none: such an
    input compiled and then refused every value it was given, from the file or ``--param``.
    """
    if port.dtype.is_numeric or (target.factor == 1.0 and target.offset == 0.0):
        return True
    bag.emit(
        codes.DTYPE,
        f"system input `{name}` reaches `{target.ref}`, a {port.dtype} port, through a linear "
        f"transformation ({transformation_text(target)}): only numbers are transformed, and "
        f"{port.dtype} values are set as they are",
        span,
        hint="remove `factor` and `offset` from this target",
        notes=declared_note(port),
    )
    return False


def _check_hexadecimal(
    name: str,
    value: Scalar | None,
    binary: list[InputTarget],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> None:
    """E043 at the input's own ``value`` when the binary ports it reaches cannot take it,
    checked as a ``parameters:`` value is: hexadecimal text of whole bytes, as FMI 3 writes
    binary start values. Unchecked, it compiled and the run ended in a fault at t=0;
    ``--param`` is checked when it is set, as for a parameter.
    """
    if not isinstance(value, str) or is_hex_bytes(value):
        return  # None: unset; another type is refused when the value is set (E043)
    bag.emit(
        codes.PARAMETER_VALUE,
        f"system input `{name}` (at `{binary[0].ref}`): a binary value is hexadecimal text of "
        f"whole bytes, got `{value}`",
        sources.value(("inputs", name, "value")),
        hint="write a binary value as hexadecimal text, e.g. `0c0d`",
    )
