"""Resolve the system's named inputs (``inputs:``) to the settable ports they reach.

A system input is a name for a value that nothing inside the system computes: an SSP
system's open ``input`` or ``parameter`` connector, or a YAML file's ``inputs:`` entry. It is
checked here like a ``parameters:`` entry, so that ``fmionnx run --param NAME=value`` later
only has to compute and set values: every target must be a parameter or an input of one
element (an FMU variable), since one value is set on each.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fmionnx.compile.endpoints import resolve_endpoint
from fmionnx.compile.ir import InputTarget, SystemInput
from fmionnx.compile.resolve import SETTABLE
from fmionnx.compile.typecheck import declared_note
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.types import ComponentInterface
from fmionnx.spec.model import InputTargetSpec, SystemSpec
from fmionnx.spec.sourcemap import SourceMap


def compile_inputs(
    spec: SystemSpec,
    interfaces: Mapping[str, ComponentInterface | None],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[SystemInput, ...]:
    """Every ``inputs:`` entry with its targets resolved; problems (E020-E023, E044) in ``bag``."""
    result = []
    for name, entry in spec.inputs.items():
        targets = []
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
            targets.append(InputTarget(ref, target.factor, target.offset))
        value = entry.value
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
