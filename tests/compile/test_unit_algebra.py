"""The unit model: SI exponents, factor and offset, and conversions between two units."""

from __future__ import annotations

import math

import pytest

from fmionnx.core.units import (
    BUILTIN_UNITS,
    Unit,
    builtin_unit,
    compose,
    conversion,
    dimension_text,
    linear_text,
)


def _convert(value: float, source: str, target: str, *, relative: bool = False) -> float:
    a, b = BUILTIN_UNITS[source], BUILTIN_UNITS[target]
    c = conversion(a, b, relative=relative)
    return c.factor * value + c.offset


@pytest.mark.parametrize(
    ("value", "source", "target", "expected"),
    [
        (90.0, "km/h", "m/s", 25.0),
        (25.0, "m/s", "km/h", 90.0),
        (0.0, "degC", "K", 273.15),
        (100.0, "degC", "K", 373.15),
        (300.0, "K", "degC", 26.85),
        (212.0, "degF", "degC", 100.0),
        (-40.0, "degF", "degC", -40.0),
        (180.0, "deg", "rad", math.pi),
        (math.pi / 2, "rad", "deg", 90.0),
        (60.0, "rpm", "rad/s", 2 * math.pi),
        (1500.0, "mm", "m", 1.5),
        (2.0, "h", "s", 7200.0),
        (3.0, "km", "m", 3000.0),
    ],
)
def test_conversion_maps_values_between_units_of_one_quantity(
    value: float, source: str, target: str, expected: float
) -> None:
    assert _convert(value, source, target) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_relative_quantity_ignores_the_offsets() -> None:
    # A temperature difference of 10 degC is 10 K, not 283.15 K.
    assert _convert(10.0, "degC", "K", relative=True) == pytest.approx(10.0)
    assert _convert(10.0, "degF", "degC", relative=True) == pytest.approx(50.0 / 9.0)


def test_conversion_between_different_quantities_is_refused() -> None:
    with pytest.raises(ValueError, match="different quantities"):
        conversion(BUILTIN_UNITS["m"], BUILTIN_UNITS["m/s"])


def test_exponents_decide_the_quantity_not_the_name() -> None:
    newton_metre, joule = BUILTIN_UNITS["N.m"], BUILTIN_UNITS["J"]
    assert newton_metre.same_dimension(joule)
    assert newton_metre.same_definition(joule)
    assert conversion(newton_metre, joule).is_identity
    # Same name, other definition (a supplier's "m" that is a millimetre).
    odd_metre = Unit("m", BUILTIN_UNITS["m"].exponents, 0.001)
    assert not odd_metre.same_definition(BUILTIN_UNITS["m"])
    assert conversion(odd_metre, BUILTIN_UNITS["m"]).factor == pytest.approx(0.001)


def test_equal_units_convert_exactly_to_the_identity() -> None:
    for unit in BUILTIN_UNITS.values():
        assert conversion(unit, unit).is_identity, unit.name
    # 1000 * (1/1000) is not exactly 1 in binary; the conversion rounds it to 1.
    kilo = Unit("km", BUILTIN_UNITS["m"].exponents, 1000.0)
    milli_kilo = Unit("x", BUILTIN_UNITS["m"].exponents, 1000.0 * (1.0 + 1e-16))
    assert conversion(kilo, milli_kilo).factor == 1.0


def test_dimension_text_names_the_si_quantity() -> None:
    assert BUILTIN_UNITS["m/s"].dimension() == "m*s^-1"
    assert BUILTIN_UNITS["N"].dimension() == "kg*m*s^-2"
    assert BUILTIN_UNITS["deg"].dimension() == "rad"
    assert BUILTIN_UNITS["1"].dimension() == "1"
    assert dimension_text((0, 0, 0, 1, 0, 0, 0, 0)) == "A"


def test_builtin_table_knows_common_names_only() -> None:
    for name in ("m", "km", "s", "h", "m/s", "km/h", "rad", "deg", "K", "degC", "N"):
        assert builtin_unit(name) is not None, name
    assert builtin_unit("px") is None
    assert builtin_unit(None) is None
    # Every MuJoCo sensor unit has a definition.
    for name in ("m", "m/s", "rad/s", "m/s2", "N", "N.m", "s", "rad"):
        assert builtin_unit(name) is not None, name


def test_compose_applies_the_first_map_then_the_second() -> None:
    factor, offset = compose((2.0, 1.0), (3.0, 5.0))  # 3 * (2x + 1) + 5
    assert (factor, offset) == (6.0, 8.0)


def test_linear_text_is_short() -> None:
    assert linear_text(1.0, 0.0) == "y = x"
    assert linear_text(0.2777777777777778, 0.0) == "y = 0.277778*x"
    assert linear_text(1.0, -273.15) == "y = x - 273.15"
