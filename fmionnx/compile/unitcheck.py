"""The unit check of a connection: compare units by what they mean, and convert.

Rules (documented in ``docs/types.md``, decisions in ``docs/decisions.md``):

* A port without a unit connects to anything; nothing is converted.
* Two units with definitions (SI exponents, factor, offset) are compared by definition, never
  by name: the same quantity converts automatically (note I033 says how), different
  quantities are E033, naming both units and their dimensions. Equal names with different
  definitions convert like any other pair.
* A unit without a definition (a name the model does not relate to SI) can only be compared
  by name: equal names pass, different names are E033 unless the connection gives its own
  ``factor``/``offset`` (the user converts, as before units were physics).
* Different quantities with the connection's own ``factor``/``offset`` are W033, not E033: the
  factor may carry a unit (a spring constant turns m into N).
* The conversion comes first, the connection's ``factor``/``offset`` after it, in the target's
  unit (SSP: the linear transformation is applied "in addition to" the unit conversion).
  A factor that equals the conversion would convert twice: W033.
* ``convert_units: false`` (SSP ``suppressUnitConversion``) converts nothing: the factor and
  offset are the whole transformation. SSP says the linear transformation is then performed
  "instead of any unit conversions", so different quantities are allowed (W033), and a
  same-quantity pair is noted (I033).
* A relative quantity (FMI ``relativeQuantity``) on either end ignores the offsets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fmionnx.compile.endpoints import ResolvedEndpoint
from fmionnx.compile.typecheck import declared_note
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.units import Unit, UnitConversion, compose, conversion, linear_text

#: How close a user's factor/offset must be to the unit conversion to count as a repeat of it.
_REPEAT_TOLERANCE = 1e-6


@dataclass(frozen=True, slots=True)
class Transform:
    """What a connection applies: the unit conversion (if any) and the total ``factor*x+offset``."""

    units: UnitConversion | None
    factor: float
    offset: float


def _described(unit: Unit) -> str:
    return f"`{unit.name}` ({unit.dimension()})"


def check_units(
    src: ResolvedEndpoint,
    dst: ResolvedEndpoint,
    span: Span,
    bag: DiagnosticBag,
    *,
    factor: float = 1.0,
    offset: float = 0.0,
    convert: bool = True,
) -> Transform | None:
    """The connection's transformation, or None after an E033."""
    given = Transform(None, factor, offset)
    a, b = src.port.unit, dst.port.unit
    if a is None or b is None:
        return given
    first, second = src.port.unit_definition, dst.port.unit_definition
    explicit = factor != 1.0 or offset != 0.0
    if first is None or second is None:
        if a == b or explicit or not convert:
            return given
        undefined = a if first is None else b
        bag.emit(
            codes.UNIT,
            f"unit mismatch: `{src.ref}` is in `{a}` but `{dst.ref}` expects `{b}`; "
            f"`{undefined}` has no definition, so the two cannot be compared",
            span,
            hint="convert with the long form `{from: ..., to: ..., factor: ..., offset: ...}`",
            notes=declared_note(dst.port),
        )
        return None
    if not first.same_dimension(second):
        why = None if convert and not explicit else ("suppressed" if not convert else "explicit")
        return _different_quantities(src, dst, (first, second), span, bag, why, given)
    relative = src.port.relative_quantity or dst.port.relative_quantity
    units = conversion(first, second, relative=relative)
    if units.is_identity:
        return given
    same_name = " (same name, different definitions)" if a == b else ""
    if not convert:
        bag.emit(
            codes.UNIT_CONVERSION,
            f"`{src.ref}` is in `{a}` and `{dst.ref}` in `{b}`{same_name}; no automatic "
            f"conversion (`convert_units: false`): the connection's {linear_text(factor, offset)} "
            "is the whole transformation",
            span,
        )
        return given
    if explicit and _repeats(units, factor, offset):
        bag.emit(
            codes.UNIT_SUSPICIOUS,
            f"the connection's factor and offset repeat the conversion from `{a}` to `{b}` "
            "that fmionnx applies itself: values would be converted twice",
            span,
            hint="drop `factor`/`offset`, or set `convert_units: false` to keep only yours",
        )
    total = compose((units.factor, units.offset), (factor, offset))
    then = f"; with the connection's factor/offset: {linear_text(*total)}" if explicit else ""
    differ = first.offset != second.offset
    kind = " (relative quantity: offsets ignored)" if relative and differ else ""
    bag.emit(
        codes.UNIT_CONVERSION,
        f"`{src.ref}` -> `{dst.ref}`: converts `{a}` to `{b}`{same_name}{kind} "
        f"({linear_text(units.factor, units.offset)}){then}",
        span,
    )
    return Transform(units, *total)


def _different_quantities(
    src: ResolvedEndpoint,
    dst: ResolvedEndpoint,
    units: tuple[Unit, Unit],
    span: Span,
    bag: DiagnosticBag,
    why: str | None,
    given: Transform,
) -> Transform | None:
    """E033; W033 when the connection says how to pass the values (``why``): its own factor
    (which then carries a unit, a spring constant in N/m, say) or a suppressed conversion."""
    first, second = units
    if why is not None:
        how = (
            f"only the connection's {linear_text(given.factor, given.offset)} is applied"
            if why == "explicit"
            else "values pass without automatic conversion (`convert_units: false`)"
        )
        bag.emit(
            codes.UNIT_SUSPICIOUS,
            f"`{src.ref}` in {_described(first)} drives `{dst.ref}` in {_described(second)}: "
            f"different quantities; {how}",
            span,
        )
        return given
    bag.emit(
        codes.UNIT,
        f"unit mismatch: `{src.ref}` is in {_described(first)} but `{dst.ref}` expects "
        f"{_described(second)}: different quantities",
        span,
        hint="connect a port of the same quantity; `convert_units: false` in the long form "
        "passes the values as they are",
        notes=declared_note(dst.port),
    )
    return None


def _repeats(units: UnitConversion, factor: float, offset: float) -> bool:
    """True when ``factor``/``offset`` are (nearly) the unit conversion itself."""
    return math.isclose(factor, units.factor, rel_tol=_REPEAT_TOLERANCE) and math.isclose(
        offset, units.offset, rel_tol=_REPEAT_TOLERANCE, abs_tol=_REPEAT_TOLERANCE
    )
