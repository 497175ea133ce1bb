"""SSP units: connector units from ``ssd:Units`` convert once, ``suppressUnitConversion`` turns
automatic conversion off, and a YAML system with a conversion survives export and import."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.spec.model import ConnectionSpec
from tests.ssp.test_import import gain, load, ssd
from tests.ssp.test_roundtrip import compiled, round_trip

UNITS = (
    "<ssd:Units>"
    '<ssc:Unit name="mm"><ssc:BaseUnit m="1" factor="0.001"/></ssc:Unit>'
    '<ssc:Unit name="m"><ssc:BaseUnit m="1"/></ssc:Unit>'
    "</ssd:Units>"
)
CONNECTOR = (
    '<ssd:Connectors><ssd:Connector name="{p}" kind="{k}"><ssc:Real unit="{u}"/>'
    "</ssd:Connector></ssd:Connectors>"
)


@pytest.fixture
def loose(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Callable[[str], Path]:
    """Write a loose ``.ssd`` beside ``resources/Gain.fmu``."""
    (tmp_path / "resources").mkdir()
    (tmp_path / "resources" / "Gain.fmu").write_bytes(fixture_fmu("Gain").read_bytes())

    def write(text: str) -> Path:
        path = tmp_path / "system.ssd"
        path.write_text(text, encoding="utf-8")
        return path

    return write


def _body(attributes: str = "", transformation: str = "") -> str:
    return (
        "<ssd:Elements>"
        + gain("a", extra=CONNECTOR.format(p="y", k="output", u="mm"))
        + gain("b", extra=CONNECTOR.format(p="u", k="input", u="m"))
        + "</ssd:Elements><ssd:Connections>"
        f'<ssd:Connection startElement="a" startConnector="y" endElement="b" endConnector="u"'
        f" {attributes}>{transformation}</ssd:Connection>"
        "</ssd:Connections>"
    )


def test_connector_units_convert_once(loose: Callable[[str], Path]) -> None:
    path = loose(ssd(_body(), after=UNITS))
    spec, found = load(path)
    assert spec is not None, found
    (connection,) = spec.connections  # type: ignore[attr-defined]
    assert isinstance(connection, ConnectionSpec)
    # The SSP settled the units (mm -> m): the compiler must not convert the ports' units too.
    assert (connection.factor, connection.convert_units) == (0.001, False)
    result = api.compile_system(path)
    assert result.system is not None, result.diagnostics
    (flat,) = result.system.connections
    assert (flat.factor, flat.offset, flat.units) == (0.001, 0.0, None)
    assert not [d for d in result.diagnostics if d.code.endswith("033")]


def test_suppress_unit_conversion_keeps_only_the_linear_transformation(
    loose: Callable[[str], Path],
) -> None:
    body = _body(
        'suppressUnitConversion="true"', '<ssc:LinearTransformation factor="0.5" offset="0"/>'
    )
    path = loose(ssd(body, after=UNITS))
    spec, found = load(path)
    assert spec is not None, found
    (connection,) = spec.connections  # type: ignore[attr-defined]
    assert isinstance(connection, ConnectionSpec)
    assert (connection.factor, connection.convert_units) == (0.5, False)
    result = api.compile_system(path)
    assert result.system is not None, result.diagnostics
    assert result.system.connections[0].factor == 0.5


YAML = """\
fmionnx: 1
name: mm
run: {{stop: 0.05, step: 0.01}}
components:
  sig:
    kind: signal
    outputs:
      length: {{constant: 1500, unit: mm}}
  gain: {{kind: fmu, path: {gain}, parameters: {{k: 2, v: [0, 0, 0]}}}}
connections:
  - sig.length -> gain.u
"""


def test_a_converted_connection_survives_export_and_import(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = tmp_path / "mm.yaml"
    system.write_text(YAML.format(gain=fixture_fmu("Gain")), encoding="utf-8")
    archive, back = round_trip(system, tmp_path)
    for path in (system, archive, back):
        (connection,) = compiled(path).connections
        assert connection.factor == 0.001, path
    imported = api.compile_system(archive)
    assert not [d for d in imported.diagnostics if d.code == "W070"], imported.diagnostics
