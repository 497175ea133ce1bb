"""Unit definitions read from FMI 2 and FMI 3 model descriptions onto ports."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fmionnx.core.types import Port
from fmionnx.core.units import Unit
from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.fmu.kind import FMU_KIND
from tests.components.fmi_xml import fmi2, fmi3, fmu_folder, fmu_zip

#: The same three units in both versions: the element and attribute names are the same.
UNITS = (
    "<UnitDefinitions>"
    '<Unit name="km/h"><BaseUnit m="1" s="-1" factor="0.2777777777777778"/></Unit>'
    '<Unit name="degC"><BaseUnit K="1" offset="273.15"/>'
    '<DisplayUnit name="degF" factor="1.8" offset="32"/></Unit>'
    '<Unit name="deg"><BaseUnit rad="1" factor="0.017453292519943295"/></Unit>'
    '<Unit name="px"/>'
    "</UnitDefinitions>"
)

KMH = Unit("km/h", (0, 1, -1, 0, 0, 0, 0, 0), 0.2777777777777778, 0.0)
DEGC = Unit("degC", (0, 0, 0, 0, 1, 0, 0, 0), 1.0, 273.15)
DEG = Unit("deg", (0, 0, 0, 0, 0, 0, 0, 1), math.pi / 180.0, 0.0)


@pytest.fixture(autouse=True)
def _fresh_cache() -> None:
    clear_cache()


def _ports(folder: Path) -> dict[str, Port]:
    return {p.name: p for p in FMU_KIND.read_interface(folder, None).ports}


def test_fmi2_units_resolve_with_exponents_factor_offset(tmp_path: Path) -> None:
    types = (
        "<TypeDefinitions>"
        '<SimpleType name="TempDiff"><Real unit="degC" relativeQuantity="true"/></SimpleType>'
        "</TypeDefinitions>"
    )
    variables = [
        '<ScalarVariable name="speed" valueReference="1" causality="output">'
        '<Real unit="km/h"/></ScalarVariable>',
        '<ScalarVariable name="temp" valueReference="2" causality="input">'
        '<Real unit="degC" start="20"/></ScalarVariable>',
        '<ScalarVariable name="rise" valueReference="3" causality="input">'
        '<Real declaredType="TempDiff" start="0"/></ScalarVariable>',
        '<ScalarVariable name="angle" valueReference="4" causality="output">'
        '<Real unit="deg" relativeQuantity="true"/></ScalarVariable>',
        '<ScalarVariable name="column" valueReference="5" causality="output">'
        '<Real unit="px"/></ScalarVariable>',
        '<ScalarVariable name="plain" valueReference="6" causality="output">'
        "<Real/></ScalarVariable>",
    ]
    folder = fmu_folder(tmp_path, "T", fmi2(variables, extra=UNITS + types))
    ports = _ports(folder)
    assert ports["speed"].unit == "km/h"
    assert ports["speed"].unit_definition == KMH
    assert ports["temp"].unit_definition == DEGC
    assert not ports["temp"].relative_quantity
    # The declared type gives both the unit and relativeQuantity.
    assert (ports["rise"].unit, ports["rise"].unit_definition) == ("degC", DEGC)
    assert ports["rise"].relative_quantity
    assert ports["angle"].unit_definition == DEG
    assert ports["angle"].relative_quantity
    # A unit without <BaseUnit> is not related to SI: a name only.
    assert (ports["column"].unit, ports["column"].unit_definition) == ("px", None)
    assert (ports["plain"].unit, ports["plain"].unit_definition) == (None, None)


def test_fmi3_units_resolve_from_type_and_variable(tmp_path: Path) -> None:
    types = (
        "<TypeDefinitions>"
        '<Float64Type name="Speed" quantity="Velocity" unit="km/h"/>'
        '<Float64Type name="TempDiff" unit="degC" relativeQuantity="true"/>'
        "</TypeDefinitions>"
    )
    variables = [
        '<Float64 name="speed" valueReference="1" causality="output" declaredType="Speed"/>',
        '<Float64 name="temp" valueReference="2" causality="input" unit="degC" start="20"/>',
        '<Float64 name="rise" valueReference="3" causality="input" declaredType="TempDiff" '
        'start="0"/>',
        '<Float32 name="angle" valueReference="4" causality="output" unit="deg"/>',
        '<Float64 name="speeds" valueReference="5" causality="output" declaredType="Speed">'
        '<Dimension start="3"/></Float64>',
    ]
    folder = fmu_folder(tmp_path, "T", fmi3(variables, extra=UNITS + types))
    ports = _ports(folder)
    assert (ports["speed"].unit, ports["speed"].unit_definition) == ("km/h", KMH)
    assert ports["temp"].unit_definition == DEGC
    assert ports["rise"].relative_quantity
    assert not ports["temp"].relative_quantity
    assert ports["angle"].unit_definition == DEG
    assert ports["speeds"].shape == (3,)
    assert ports["speeds"].unit_definition == KMH


def test_fmi2_array_members_keep_their_unit_definition(tmp_path: Path) -> None:
    variables = [
        f'<ScalarVariable name="v[{i}]" valueReference="{i}" causality="output">'
        '<Real unit="km/h"/></ScalarVariable>'
        for i in (1, 2, 3)
    ]
    folder = fmu_folder(tmp_path, "T", fmi2(variables, extra=UNITS))
    port = _ports(folder)["v"]
    assert port.shape == (3,)
    assert port.unit_definition == KMH


def test_units_are_read_from_a_model_description_only_archive(tmp_path: Path) -> None:
    variables = [
        '<ScalarVariable name="speed" valueReference="1" causality="output">'
        '<Real unit="km/h"/></ScalarVariable>'
    ]
    archive = fmu_zip(
        tmp_path / "T.fmu", {"modelDescription.xml": fmi2(variables, extra=UNITS).encode()}
    )
    port = FMU_KIND.read_interface(archive, None).port("speed")
    assert port is not None
    assert port.unit_definition == KMH
