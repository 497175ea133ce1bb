"""Units as physics: SI base exponents, a factor and an offset, and the conversion between two.

FMI 2/3 (``<UnitDefinitions><Unit><BaseUnit kg= m= s= A= K= mol= cd= rad= factor= offset=/>``)
and SSP (``ssc:Unit``/``ssc:BaseUnit``) define a unit the same way: a value ``x`` in the unit
is ``factor * x + offset`` in the SI unit whose exponents are given. Two units measure the same
quantity when their exponents agree, and then one converts into the other by a linear map.
Comparing names instead would call ``km/h`` and ``m/s`` incompatible and two different
definitions that happen to share a name (``m`` of one supplier, ``m`` of another) equal.

Ports of kinds whose models carry no unit definitions (ONNX, MuJoCo, signals) get theirs from
:data:`BUILTIN_UNITS`, a small table of common units named as Modelica and the FMI examples
name them (``m/s2``, ``N.m``, ``degC``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The SI base units FMI and SSP give exponents for, in their attribute order.
BASE_UNITS: tuple[str, ...] = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")

#: Exponents of a dimensionless unit.
DIMENSIONLESS: tuple[int, ...] = (0,) * len(BASE_UNITS)


@dataclass(frozen=True, slots=True)
class Unit:
    """A unit definition: ``value_SI = factor * value + offset`` in the SI unit of ``exponents``.

    ``exponents`` are the powers of :data:`BASE_UNITS` in that order (``m/s`` is
    ``(0, 1, -1, 0, 0, 0, 0, 0)``). ``name`` is how the model writes the unit; it is what
    messages, tables and plot labels show.
    """

    name: str
    exponents: tuple[int, ...] = DIMENSIONLESS
    factor: float = 1.0
    offset: float = 0.0

    def same_dimension(self, other: Unit) -> bool:
        """True when both measure the same quantity (equal SI exponents)."""
        return self.exponents == other.exponents

    def same_definition(self, other: Unit) -> bool:
        """True when a value means the same in both: same exponents, factor and offset."""
        return (
            self.exponents == other.exponents
            and self.factor == other.factor
            and self.offset == other.offset
        )

    def dimension(self) -> str:
        """The SI quantity as text: ``m*s^-1``, ``kg*m*s^-2``, ``1`` for dimensionless."""
        return dimension_text(self.exponents)


def dimension_text(exponents: tuple[int, ...]) -> str:
    """``m*s^-1`` for the exponents of m/s; ``1`` when every exponent is zero."""
    parts = []
    for base, power in zip(BASE_UNITS, exponents, strict=True):
        if power == 1:
            parts.append(base)
        elif power != 0:
            parts.append(f"{base}^{power}")
    return "*".join(parts) if parts else "1"


@dataclass(frozen=True, slots=True)
class UnitConversion:
    """The conversion a connection applies between its ends' units: ``y = factor*x + offset``.

    Kept in the compiled system beside the connection's total transformation so that
    ``validate``, ``graph`` and the exporters can say where a factor came from.
    """

    source: str
    target: str
    factor: float
    offset: float

    @property
    def is_identity(self) -> bool:
        """True when the conversion changes no value."""
        return self.factor == 1.0 and self.offset == 0.0


def conversion(source: Unit, target: Unit, *, relative: bool = False) -> UnitConversion:
    """The linear map taking a value in ``source`` to the same quantity in ``target``.

    Both units must have the same dimension. In SI, ``f_s*x + o_s = f_t*y + o_t``, so
    ``y = (f_s/f_t)*x + (o_s - o_t)/f_t``. A relative quantity (FMI ``relativeQuantity``: a
    temperature difference, say) ignores the offsets: 10 degC of difference are 10 K.
    """
    if not source.same_dimension(target):
        msg = f"`{source.name}` and `{target.name}` measure different quantities"
        raise ValueError(msg)
    factor = source.factor / target.factor
    offset = 0.0 if relative else (source.offset - target.offset) / target.factor
    if math.isclose(factor, 1.0, rel_tol=1e-15, abs_tol=0.0):
        factor = 1.0  # 1000 * 0.001 is not exactly 1 in binary; keep equal units exact
    return UnitConversion(source.name, target.name, factor, offset)


def compose(first: tuple[float, float], then: tuple[float, float]) -> tuple[float, float]:
    """``(factor, offset)`` of applying ``first`` and then ``then`` (both ``y = a*x + b``)."""
    return then[0] * first[0], then[0] * first[1] + then[1]


def linear_text(factor: float, offset: float) -> str:
    """``y = 0.277778*x`` or ``y = x + 273.15`` for messages."""
    scaled = "x" if factor == 1.0 else f"{factor:.6g}*x"
    if offset == 0.0:
        return f"y = {scaled}"
    sign = "-" if offset < 0 else "+"
    return f"y = {scaled} {sign} {abs(offset):.6g}"


def _u(name: str, factor: float = 1.0, offset: float = 0.0, **powers: int) -> Unit:
    exponents = tuple(powers.get(base, 0) for base in BASE_UNITS)
    return Unit(name, exponents, factor, offset)


_DEG = math.pi / 180.0

#: Common units by the names Modelica and FMI models use. Models that define their units
#: (FMUs, SSP files) never need this table; it serves kinds whose models carry names only.
BUILTIN_UNITS: dict[str, Unit] = {
    u.name: u
    for u in (
        _u("1"),
        # length, area, volume
        _u("m", m=1),
        _u("km", 1000.0, m=1),
        _u("cm", 0.01, m=1),
        _u("mm", 0.001, m=1),
        _u("m2", m=2),
        _u("m3", m=3),
        _u("l", 0.001, m=3),
        # time, frequency
        _u("s", s=1),
        _u("ms", 0.001, s=1),
        _u("min", 60.0, s=1),
        _u("h", 3600.0, s=1),
        _u("Hz", s=-1),
        # velocity, acceleration
        _u("m/s", m=1, s=-1),
        _u("km/h", 1000.0 / 3600.0, m=1, s=-1),
        _u("m/s2", m=1, s=-2),
        # angle, angular velocity
        _u("rad", rad=1),
        _u("deg", _DEG, rad=1),
        _u("rad/s", rad=1, s=-1),
        _u("deg/s", _DEG, rad=1, s=-1),
        _u("rpm", 2.0 * math.pi / 60.0, rad=1, s=-1),
        _u("rev/min", 2.0 * math.pi / 60.0, rad=1, s=-1),
        _u("rad/s2", rad=1, s=-2),
        # temperature
        _u("K", K=1),
        _u("degC", 1.0, 273.15, K=1),
        _u("degF", 5.0 / 9.0, 273.15 - 32.0 * 5.0 / 9.0, K=1),
        # mass, force, torque, energy, power, pressure
        _u("kg", kg=1),
        _u("g", 0.001, kg=1),
        _u("N", kg=1, m=1, s=-2),
        _u("N.m", kg=1, m=2, s=-2),
        _u("J", kg=1, m=2, s=-2),
        _u("W", kg=1, m=2, s=-3),
        _u("kW", 1000.0, kg=1, m=2, s=-3),
        _u("Pa", kg=1, m=-1, s=-2),
        _u("kPa", 1000.0, kg=1, m=-1, s=-2),
        _u("bar", 1.0e5, kg=1, m=-1, s=-2),
        # electricity
        _u("A", A=1),
        _u("V", kg=1, m=2, s=-3, A=-1),
        _u("Ohm", kg=1, m=2, s=-3, A=-2),
        # amount of substance, luminous intensity
        _u("mol", mol=1),
        _u("cd", cd=1),
    )
}


def builtin_unit(name: str | None) -> Unit | None:
    """The built-in definition of ``name``, or None (no name, or a name the table lacks)."""
    if name is None:
        return None
    return BUILTIN_UNITS.get(name)
