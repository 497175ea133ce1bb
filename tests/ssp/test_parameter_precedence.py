"""Parameter precedence in SSP files, and where each value came from (issue #33).

Two archives hold the same values, once in one system-level ``.ssv`` with dotted names, once
inline on each level. A plain run of each must give the same outputs: the parameter
connector ``k_cref = 30``, wired to ``addP.k``, wins over the direct binding ``addP.k = 10``
in both (SSP 2.0, 5.3.2 "Connections": the connection is the connector's one source; 5.2.3
"ParameterBindings": a higher level wins over a lower one). Gain: ``y = k * u``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from tests.ssp.conftest import SSP_NAMESPACES, write_ssp

FMU = "application/x-fmu-sharedlibrary"


def _values(entries: dict[str, float]) -> str:
    return "".join(
        f'<ssv:Parameter name="{name}"><ssv:Real value="{value}"/></ssv:Parameter>'
        for name, value in entries.items()
    )


def _inline(entries: dict[str, float]) -> str:
    return (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        f'<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>{_values(entries)}'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        "</ssd:ParameterBindings>"
    )


def _gain(name: str, binding: str = "") -> str:
    return (
        f'<ssd:Component name="{name}" type="{FMU}" source="resources/Gain.fmu">'
        '<ssd:Connectors><ssd:Connector name="k" kind="parameter"><ssc:Real/></ssd:Connector>'
        '<ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector></ssd:Connectors>'
        f"{binding}</ssd:Component>"
    )


def _ssd(root_binding: str, add_binding: str = "", other_binding: str = "") -> str:
    return (
        (
            '<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssd:SystemStructureDescription {SSP_NAMESPACES} name="prec" version="2.0">'
            '<ssd:System name="root"><ssd:Connectors>'
            '<ssd:Connector name="k_cref" kind="parameter"><ssc:Real/></ssd:Connector>'
            "</ssd:Connectors>"
            f"{root_binding}<ssd:Elements>"
            '<ssd:System name="inner"><ssd:Elements>'
            f"{_gain('addP', add_binding)}</ssd:Elements></ssd:System>"
            f"{_gain('other', other_binding)}"
            "</ssd:Elements><ssd:Connections>"
            '<ssd:Connection startElement="" startConnector="k_cref" endElement="inner" '
            'endConnector="k_in"/>'
            "</ssd:Connections></ssd:System>"
            '<ssd:DefaultExperiment startTime="0" stopTime="0.1"/>'
            "</ssd:SystemStructureDescription>"
        )
        .replace(
            # the nested system passes the value on through its own parameter connector
            '<ssd:System name="inner"><ssd:Elements>',
            '<ssd:System name="inner"><ssd:Connectors>'
            '<ssd:Connector name="k_in" kind="parameter"><ssc:Real/></ssd:Connector>'
            "</ssd:Connectors><ssd:Elements>",
        )
        .replace(
            "</ssd:Elements></ssd:System>",
            '</ssd:Elements><ssd:Connections><ssd:Connection startConnector="k_in" '
            'endElement="addP" endConnector="k"/></ssd:Connections></ssd:System>',
            1,
        )
    )


#: The same seven values: the connector, then the direct binding it must win over.
SSV_VALUES = {
    "k_cref": 30.0,
    "inner.addP.u": 2.0,
    "inner.addP.k": 10.0,
    "other.k": 5.0,
    "other.u": 1.5,
    "inner.addP.x_unused_by_gain": 0.0,
}


@pytest.fixture
def archives(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> dict[str, Path]:
    gain = fixture_fmu("Gain")
    entries = {k: v for k, v in SSV_VALUES.items() if "unused" not in k}
    ssv = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
        f' version="2.0" name="values"><ssv:Parameters>{_values(entries)}</ssv:Parameters>'
        "</ssv:ParameterSet>"
    )
    with_ssv = _ssd(
        '<ssd:ParameterBindings><ssd:ParameterBinding source="resources/values.ssv"/>'
        "</ssd:ParameterBindings>"
    )
    inline = _ssd(
        _inline({"k_cref": 30.0}),
        _inline({"u": 2.0, "k": 10.0}),
        _inline({"k": 5.0, "u": 1.5}),
    )
    return {
        "ssv": write_ssp(
            tmp_path / "ssv.ssp",
            {
                "SystemStructure.ssd": with_ssv,
                "resources/Gain.fmu": gain,
                "resources/values.ssv": ssv,
            },
        ),
        "inline": write_ssp(
            tmp_path / "inline.ssp",
            {"SystemStructure.ssd": inline, "resources/Gain.fmu": gain},
        ),
    }


@pytest.mark.parametrize("layout", ["ssv", "inline"])
def test_the_connected_parameter_connector_wins_over_a_direct_binding(
    archives: dict[str, Path], layout: str
) -> None:
    result = fmionnx.load(archives[layout]).run()
    assert result["inner.addP.y"][-1] == 60.0  # k = 30 (k_cref), not 10; u = 2
    assert result["other.y"][-1] == 7.5


def test_both_layouts_give_the_same_outputs(archives: dict[str, Path]) -> None:
    ssv = fmionnx.load(archives["ssv"]).run()
    inline = fmionnx.load(archives["inline"]).run()
    assert list(ssv.signals) == list(inline.signals)
    assert "inner.addP.y" in ssv.signals  # every output is recorded by default
    for name in ssv.signals:
        assert np.array_equal(ssv[name], inline[name]), name


@pytest.mark.parametrize(("layout", "source"), [("ssv", "ssv file"), ("inline", "ssp inline")])
def test_run_json_lists_every_value_set_with_its_source(
    archives: dict[str, Path], tmp_path: Path, layout: str, source: str
) -> None:
    out = tmp_path / f"out-{layout}"
    result = CliRunner().invoke(
        app, ["run", str(archives[layout]), "--out", str(out), "-q", "--param", "other.u=4"]
    )
    assert result.exit_code == 0, result.output
    document = json.loads((out / "run.json").read_text())
    table = {entry["name"]: (entry["value"], entry["source"]) for entry in document["parameters"]}
    assert table == {
        "inner.addP.k": (30.0, source),
        "inner.addP.u": (2.0, source),
        "other.k": (5.0, source),
        "other.u": (4.0, "command line"),
    }


def test_run_json_names_the_system_file_for_yaml_values(
    fixture_fmu: Callable[[str], Path], tmp_path: Path
) -> None:
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: g\nrun: {stop: 0.1, step: 0.05}\ncomponents:\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{k: 3.0, u: 2.0}}}}\n"
    )
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(system), "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    document = json.loads((out / "run.json").read_text())
    assert document["parameters"] == [
        {"name": "g.k", "value": 3.0, "source": "system file"},
        {"name": "g.u", "value": 2.0, "source": "system file"},
    ]
