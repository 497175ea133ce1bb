"""System connectors as other tools write them: junctions, top-level parameters, open inputs.

The archive is laid out as OMSimulator exports one (version 2.0 with the SSP1 namespaces,
``startElement=""`` for the system's own connectors, the root system's values in an ``.ssv``
renamed by an ``.ssm`` that maps one value onto several connectors), after the standard's
own examples of a system with input, output and parameter connectors and a nested system
with its own. Every number below is worked out by hand in the comment next to it.
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from lxml import etree

import fmionnx
from fmionnx import api
from fmionnx.compile.overrides import OverrideError
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.types import PortRef
from fmionnx.spec.frontends import load_system
from fmionnx.spec.model import ConnectionSpec, SystemSpec
from tests.ssp.conftest import SSP_NAMESPACES, write_ssp

FMU = "application/x-fmu-sharedlibrary"


def real(name: str, kind: str, unit: str = "") -> str:
    unit_attribute = f' unit="{unit}"' if unit else ""
    return f'<ssd:Connector name="{name}" kind="{kind}"><ssc:Real{unit_attribute}/></ssd:Connector>'


def connection(start: str, end: str, factor: float | None = None, offset: float = 0.0) -> str:
    """``a.b`` or ``.b`` (the system's own connector, written as OMSimulator does)."""
    (se, sc), (ee, ec) = start.split("."), end.split(".")
    body = ""
    if factor is not None:
        body = f'<ssc:LinearTransformation factor="{factor}" offset="{offset}"/>'
    return (
        f'<ssd:Connection startElement="{se}" startConnector="{sc}" endElement="{ee}" '
        f'endConnector="{ec}">{body}</ssd:Connection>'
    )


def component(name: str, fmu: str, connectors: str) -> str:
    return (
        f'<ssd:Component name="{name}" type="{FMU}" source="resources/{fmu}.fmu">'
        f"<ssd:Connectors>{connectors}</ssd:Connectors></ssd:Component>"
    )


ROOT_BINDING = (
    "<ssd:ParameterBindings>"
    '<ssd:ParameterBinding source="resources/top.ssv">'
    '<ssd:ParameterMapping source="resources/top.ssm"/>'
    "</ssd:ParameterBinding></ssd:ParameterBindings>"
)

#: Root values: `cosim_k` = 3 and `drive_value` = 4, renamed by TOP_SSM.
TOP_SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    version="2.0" name="parameters">
  <ssv:Parameters>
    <ssv:Parameter name="cosim_k"><ssv:Real value="3"/></ssv:Parameter>
    <ssv:Parameter name="drive_value"><ssv:Real value="4"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"""

#: One source onto two targets (as OMSimulator writes), one entry with a transformation:
#: k_top = 2 * 3 = 6, gain_k = 3, drive = 4.
TOP_SSM = """<?xml version="1.0" encoding="UTF-8"?>
<ssm:ParameterMapping xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="2.0">
  <ssm:MappingEntry source="cosim_k" target="k_top">
    <ssc:LinearTransformation factor="2"/>
  </ssm:MappingEntry>
  <ssm:MappingEntry source="cosim_k" target="gain_k"/>
  <ssm:MappingEntry source="drive_value" target="drive"/>
</ssm:ParameterMapping>
"""


def top_ssd(*, binding: str = ROOT_BINDING, extra_root: str = "", extra_sub: str = "") -> str:
    """Root system `top` with connectors drive (input), k_top and gain_k (parameters), y
    (output); components integ and gain1; nested system `sub` with u_in (input), k_in
    (parameter), y_out (output) around gain2.

    drive -(x0.5)-> integ.u;  integ.x -> gain1.u;  gain_k -> gain1.k;
    gain1.y -(x2 +1)-> sub.u_in -> gain2.u;  k_top -(x2 +1)-> sub.k_in -(x0.5)-> gain2.k;
    gain2.y -> sub.y_out -> y.
    """
    sub = (
        '<ssd:System name="sub"><ssd:Connectors>'
        + real("u_in", "input")
        + real("k_in", "parameter")
        + real("y_out", "output")
        + "</ssd:Connectors><ssd:Elements>"
        + component(
            "gain2", "Gain", real("u", "input") + real("k", "parameter") + real("y", "output")
        )
        + "</ssd:Elements><ssd:Connections>"
        + connection(".u_in", "gain2.u")
        + connection(".k_in", "gain2.k", 0.5)
        + connection("gain2.y", ".y_out")
        + extra_sub
        + "</ssd:Connections></ssd:System>"
    )
    root = (
        '<ssd:System name="top"><ssd:Connectors>'
        + real("drive", "input")
        + real("k_top", "parameter")
        + real("gain_k", "parameter")
        + real("y", "output")
        + "</ssd:Connectors>"
        + binding
        + "<ssd:Elements>"
        + component("integ", "Integrator", real("u", "input") + real("x", "output"))
        + component(
            "gain1", "Gain", real("u", "input") + real("k", "parameter") + real("y", "output")
        )
        + sub
        + "</ssd:Elements><ssd:Connections>\n"
        + connection(".drive", "integ.u", 0.5)
        + "\n"
        + connection("integ.x", "gain1.u")
        + "\n"
        + connection(".gain_k", "gain1.k")
        + "\n"
        + connection("gain1.y", "sub.u_in", 2, 1)
        + "\n"
        + connection(".k_top", "sub.k_in", 2, 1)
        + "\n"
        + connection("sub.y_out", ".y")
        + "\n"
        + extra_root
        + "</ssd:Connections></ssd:System>"
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<ssd:SystemStructureDescription {SSP_NAMESPACES} name="top" version="2.0">\n'
        f"{root}\n"
        '<ssd:DefaultExperiment startTime="0" stopTime="1"/>\n'
        "</ssd:SystemStructureDescription>\n"
    )


@pytest.fixture
def make_ssp(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Callable[..., Path]:
    """Zip an SSD text with the test FMUs and the root's `.ssv`/`.ssm` into an archive."""
    counter = iter(range(1000))

    def make(text: str, ssv: str = TOP_SSV) -> Path:
        return write_ssp(
            tmp_path / f"top{next(counter)}.ssp",
            {
                "SystemStructure.ssd": text,
                "resources/Gain.fmu": fixture_fmu("Gain"),
                "resources/Integrator.fmu": fixture_fmu("Integrator"),
                "resources/top.ssv": ssv,
                "resources/top.ssm": TOP_SSM,
            },
        )

    return make


def load(path: Path) -> tuple[SystemSpec | None, list[tuple[str, int, str]]]:
    bag = DiagnosticBag()
    loaded = load_system(path, bag)
    found = [(d.code, d.span.line if d.span else 0, d.message) for d in bag.sorted()]
    return loaded.spec, found


def line_of(text: str, needle: str) -> int:
    """1-based line of the first occurrence of ``needle`` in ``text``."""
    return text[: text.index(needle)].count("\n") + 1


def test_top_level_parameters_flow_along_connections_with_transformations(make_ssp) -> None:
    spec, found = load(make_ssp(top_ssd()))
    assert spec is not None, found
    # drive = 4 -> integ.u = 0.5 * 4 = 2; gain_k = 3 -> gain1.k = 3;
    # k_top = 2 * 3 = 6 -> sub.k_in = 2 * 6 + 1 = 13 -> gain2.k = 0.5 * 13 = 6.5.
    assert spec.components["integ"].parameters == {"u": 2.0}
    assert spec.components["gain1"].parameters == {"k": 3.0}
    assert spec.components["sub.gain2"].parameters == {"k": 6.5}
    # Bound connectors are values, not signals: no connection from them, no warning.
    assert not [f for f in found if f[0] == "W070"], found


def test_system_connectors_become_direct_connections(make_ssp) -> None:
    spec, found = load(make_ssp(top_ssd()))
    assert spec is not None, found
    assert spec.connections[0] == "integ.x -> gain1.u"
    through = spec.connections[1]
    assert isinstance(through, ConnectionSpec)
    assert (through.from_, through.to, through.factor, through.offset) == (
        "gain1.y",
        "sub.gain2.u",
        2.0,
        1.0,
    )
    # gain2.y -> sub.y_out -> y: the root output connector reaches no component.
    assert len(spec.connections) == 2


def test_run_matches_the_values_worked_out_by_hand(make_ssp) -> None:
    # gain2.y leaves through the root's output connector only: recorded by name.
    record = (PortRef("integ", "x"), PortRef("gain1", "y"), PortRef("sub.gain2", "y"))
    run = fmionnx.load(make_ssp(top_ssd())).run(isolate="none", signals=record)
    # integ.u = 2: x(1) = 2; gain1.y = 3 * 2 = 6; gain2.u = 2 * 6 + 1 = 13;
    # gain2.y = 6.5 * 13 = 84.5.
    x, y1, y2 = run["integ.x"][-1], run["gain1.y"][-1], run["sub.gain2.y"][-1]
    assert x == pytest.approx(2.0)
    assert y1 == pytest.approx(3.0 * x)
    assert y2 == pytest.approx(6.5 * (2.0 * y1 + 1.0))
    assert y2 == pytest.approx(84.5)


def test_outer_value_overrides_the_components_own_binding(make_ssp, tmp_path: Path) -> None:
    inline = (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="k"><ssv:Real value="10"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        "</ssd:ParameterBindings>"
    )
    text = top_ssd().replace(
        '<ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector></ssd:Connectors>'
        "</ssd:Component>",
        '<ssd:Connector name="y" kind="output"><ssc:Real/></ssd:Connector></ssd:Connectors>'
        f"{inline}</ssd:Component>",
        1,
    )
    assert inline in text
    spec, found = load(make_ssp(text))
    assert spec is not None, found
    # gain1's own k = 10 loses against the root's gain_k = 3 (outer over inner).
    assert spec.components["gain1"].parameters == {"k": 3.0}


def test_values_for_nested_system_connectors_by_dotted_name(make_ssp) -> None:
    inline = (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="sub.k_in"><ssv:Real value="8"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        "</ssd:ParameterBindings>"
    )
    spec, found = load(make_ssp(top_ssd(binding=inline)))
    assert spec is not None, found
    # sub.k_in = 8 -> gain2.k = 0.5 * 8 = 4.
    assert spec.components["sub.gain2"].parameters == {"k": 4.0}


def test_a_value_on_a_top_level_connector_that_leads_nowhere_is_kept(make_ssp) -> None:
    # As OMSimulator writes a system's inputs with values and nothing connected yet: the
    # standard's parameter binding gives the connector that value, and OMSimulator keeps it
    # (issue #33: fmionnx dropped it with W070)
    text = top_ssd().replace(real("y", "output"), real("y", "output") + real("spare", "input"))
    inline = (
        "<ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="spare"><ssv:Real value="-20"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
    )
    text = text.replace(
        "</ssd:ParameterBinding></ssd:ParameterBindings>",
        f"</ssd:ParameterBinding>{inline}</ssd:ParameterBindings>",
        1,
    )
    spec, found = load(make_ssp(text))
    assert spec is not None, found
    assert not [f for f in found if f[0] == "W070"], found
    assert spec.inputs["spare"].to == []
    assert spec.inputs["spare"].value == -20.0
    compiled = fmionnx.load(make_ssp(text)).compiled
    (kept,) = [i for i in compiled.inputs if i.name == "spare"]
    assert (kept.value, kept.targets, str(kept.source)) == (-20.0, (), "ssp inline")


def test_a_value_on_a_nested_connector_that_leads_nowhere_is_a_warning(make_ssp) -> None:
    text = top_ssd().replace(
        real("y_out", "output"), real("y_out", "output") + real("spare", "input")
    )
    inline = (
        "<ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="sub.spare"><ssv:Real value="1"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
    )
    text = text.replace(
        "</ssd:ParameterBinding></ssd:ParameterBindings>",
        f"</ssd:ParameterBinding>{inline}</ssd:ParameterBindings>",
        1,
    )
    spec, found = load(make_ssp(text))
    assert spec is not None, found
    assert [(c, m) for c, _, m in found if c == "W070"] == [
        (
            "W070",
            "`sub.spare` sets connector `spare` of system `sub`, which leads to no "
            "component connector; the value is not used",
        )
    ]


def test_unknown_name_on_a_system_is_e072(make_ssp) -> None:
    inline = (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="2.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="nothing"><ssv:Real value="8"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        "</ssd:ParameterBindings>"
    )
    text = top_ssd(binding=inline)
    spec, found = load(make_ssp(text))
    assert spec is None
    assert [(c, line) for c, line, _ in found if c.startswith("E")] == [
        ("E072", line_of(text, 'name="nothing"'))
    ]


def test_output_connector_driven_twice_is_e073(make_ssp) -> None:
    text = top_ssd(extra_root=connection("gain1.y", ".y"))
    spec, found = load(make_ssp(text))
    assert spec is None
    errors = [(c, line, m) for c, line, m in found if c.startswith("E")]
    assert errors == [
        (
            "E073",
            line_of(text, 'startElement="gain1" startConnector="y" endElement="" '),
            "connector `y` of the root system `top` is driven by 2 connections; a system "
            "connector passes on one signal",
        )
    ]


def test_cycle_through_system_connectors_is_e073(make_ssp) -> None:
    # sub passes u_in straight to y_out, and the root feeds y_out back into u_in.
    text = top_ssd(extra_sub=connection(".u_in", ".y_out"), extra_root="")
    text = text.replace(
        connection("gain1.y", "sub.u_in", 2, 1), connection("sub.y_out", "sub.u_in")
    )
    text = text.replace(connection("gain2.y", ".y_out"), "")
    spec, found = load(make_ssp(text))
    assert spec is None
    errors = [(c, m) for c, _, m in found if c.startswith("E")]
    assert errors == [
        (
            "E073",
            "connections through system connectors form a cycle: sub.y_out -> sub.u_in -> sub.y_out",
        )
    ]


def test_boolean_value_through_a_transformation_is_e071(make_ssp) -> None:
    # drive_value reaches integ.u through `factor="0.5"`: a Boolean cannot be scaled.
    ssv = TOP_SSV.replace('<ssv:Real value="4"/>', '<ssv:Boolean value="true"/>')
    spec, found = load(make_ssp(top_ssd(), ssv=ssv))
    assert spec is None
    assert [(c, line) for c, line, _ in found if c.startswith("E")] == [
        ("E071", line_of(ssv, 'name="drive_value"'))
    ]


# --- open system connectors: named inputs of the system, set with --param


def test_open_connectors_become_named_system_inputs(make_ssp) -> None:
    spec, found = load(make_ssp(top_ssd(binding="")))
    assert spec is not None, found
    assert not [f for f in found if f[0] == "W070"], found
    inputs = {
        name: [t if isinstance(t, str) else t.model_dump() for t in entry.to]
        for name, entry in spec.inputs.items()
    }
    # k_top -(x2 +1)-> sub.k_in -(x0.5)-> gain2.k: 0.5 * (2 v + 1) = 1.0 v + 0.5.
    assert inputs == {
        "drive": [{"to": "integ.u", "factor": 0.5, "offset": 0.0}],
        "k_top": [{"to": "sub.gain2.k", "factor": 1.0, "offset": 0.5}],
        "gain_k": ["gain1.k"],
    }
    # The targets are set from outside: no warning about an unconnected integ.u.
    result = api.compile_system(make_ssp(top_ssd(binding="")))
    assert result.ok, result.diagnostics
    loose = [d.message for d in result.diagnostics if d.code == "W030"]
    assert not [m for m in loose if "integ.u" in m or "gain2.k" in m], loose


def test_nested_open_connector_is_named_with_its_system(make_ssp) -> None:
    text = top_ssd(binding="").replace(connection(".k_top", "sub.k_in", 2, 1), "")
    spec, found = load(make_ssp(text))
    assert spec is not None, found
    assert set(spec.inputs) == {"drive", "gain_k", "sub.k_in"}
    (target,) = spec.inputs["sub.k_in"].to
    assert not isinstance(target, str)
    assert (target.to, target.factor, target.offset) == ("sub.gain2.k", 0.5, 0.0)


def test_param_sets_system_inputs_like_the_bound_values(make_ssp) -> None:
    system = fmionnx.load(make_ssp(top_ssd(binding="")))
    record = (PortRef("integ", "x"), PortRef("gain1", "y"), PortRef("sub.gain2", "y"))
    # The values TOP_SSV and TOP_SSM gave: drive = 4, k_top = 6, gain_k = 3; same results:
    # integ.u = 2, x(1) = 2, gain1.y = 6, gain2.k = 6 + 0.5 = 6.5, gain2.y = 6.5 * 13 = 84.5.
    run = system.run(isolate="none", params={"drive": 4, "k_top": 6, "gain_k": 3}, signals=record)
    assert run["integ.x"][-1] == pytest.approx(2.0)
    assert run["sub.gain2.y"][-1] == pytest.approx(84.5)
    # Unset, the targets keep their start values: integ.u = 0, so everything stays at 0 but
    # gain2.u = 2 * 0 + 1 = 1 and gain2.k = 2 (the Gain FMU's start): gain2.y = 2.
    run = system.run(isolate="none", signals=record)
    assert run["integ.x"][-1] == pytest.approx(0.0)
    assert run["sub.gain2.y"][-1] == pytest.approx(2.0)


def test_param_on_a_system_input_refuses_what_cannot_be_set(make_ssp) -> None:
    system = fmionnx.load(make_ssp(top_ssd(binding="")))
    with pytest.raises(OverrideError, match=r"a system input takes one value"):
        system.with_overrides(params={"drive": [1, 2]})
    with pytest.raises(OverrideError, match=r"reaches `integ.u` through a linear"):
        system.with_overrides(params={"drive": True})
    with pytest.raises(OverrideError, match=r"system inputs: drive, k_top, gain_k"):
        system.with_overrides(params={"driv": 1})


def test_cli_run_param_names_the_open_connector(make_ssp, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    archive = make_ssp(top_ssd(binding=""))
    out = tmp_path / "out"
    args = ["run", str(archive), "--out", str(out), "--param", "drive=4", "--param", "gain_k=3"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    rows = (out / "results.csv").read_text(encoding="utf-8").splitlines()
    header, last = rows[0].split(","), rows[-1].split(",")
    # integ.u = 0.5 * 4 = 2: x(1) = 2; gain1.y = 3 * 2 = 6.
    assert float(last[header.index("integ.x")]) == pytest.approx(2.0)
    assert float(last[header.index("gain1.y")]) == pytest.approx(6.0)


def test_yaml_inputs_must_reach_settable_ports(tmp_path: Path, fixture_fmu) -> None:
    system = tmp_path / "inputs.yaml"
    system.write_text(
        "fmionnx: 1\n"
        "name: inputs\n"
        "run: {stop: 1, step: 0.1}\n"
        "components:\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "inputs:\n"
        "  level: {to: [g.k, {to: g.u, factor: 2}]}\n"
        "  wrong: {to: [g.y]}\n",
        encoding="utf-8",
    )
    result = api.compile_system(system)
    assert [
        (d.code, d.span.line if d.span else 0) for d in result.diagnostics if d.code.startswith("E")
    ] == [("E044", 8)]
    system.write_text(system.read_text(encoding="utf-8").replace("  wrong: {to: [g.y]}\n", ""))
    loaded = fmionnx.load(system)
    # level = 1.5: g.k = 1.5, g.u = 3: g.y = 4.5.
    run = loaded.run(isolate="none", params={"level": 1.5}, signals=(PortRef("g", "y"),))
    assert run["g.y"][-1] == pytest.approx(4.5)


def test_system_inputs_survive_export_and_convert(tmp_path: Path, fixture_fmu) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app
    from fmionnx.spec.ssp_xml import schema

    system = tmp_path / "inputs.yaml"
    system.write_text(
        "fmionnx: 1\n"
        "name: inputs\n"
        "run: {stop: 1, step: 0.1}\n"
        "components:\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "inputs:\n"
        "  level: {to: [g.k, {to: g.u, factor: 2, offset: 1}]}\n"
        "  sub.gain: {to: [g.k]}\n"
        "  spare: {to: [], value: -20.0}\n",
        encoding="utf-8",
    )
    archive = tmp_path / "inputs.ssp"
    runner = CliRunner()
    result = runner.invoke(app, ["export", str(system), "-o", str(archive)])
    assert result.exit_code == 0, result.output
    with zipfile.ZipFile(archive) as members:
        ssd = etree.fromstring(members.read("SystemStructure.ssd"))
    assert schema("ssd", "1").validate(etree.ElementTree(ssd)), schema("ssd", "1").error_log
    spec, found = load(archive)
    assert spec is not None, found
    assert {
        n: [t if isinstance(t, str) else t.model_dump() for t in e.to]
        for n, e in spec.inputs.items()
    } == {
        "level": ["g.k", {"to": "g.u", "factor": 2.0, "offset": 1.0}],
        "sub.gain": ["g.k"],
        "spare": [],
    }
    # a system input holding a value of its own is written as a bound root connector
    assert spec.inputs["spare"].value == -20.0
    converted = tmp_path / "back.yaml"
    result = runner.invoke(app, ["convert", str(archive), "-o", str(converted)])
    assert result.exit_code == 0, result.output
    # level = 1.5 through the converted file: g.k = 1.5, g.u = 2 * 1.5 + 1 = 4: g.y = 6.
    run = fmionnx.load(converted).run(
        isolate="none", params={"level": 1.5}, signals=(PortRef("g", "y"),)
    )
    assert run["g.y"][-1] == pytest.approx(6.0)


def test_a_long_cycle_of_system_connectors_is_one_short_e073(tmp_path: Path) -> None:
    # A hostile file: 5000 connectors of one system passed round in a circle. The graph is
    # walked without recursion, and the message names the ends of the cycle only.
    count = 5000
    connectors = "".join(f'<ssd:Connector name="c{i}" kind="input"/>' for i in range(count))
    edges = "".join(
        f'<ssd:Connection startConnector="c{i}" endConnector="c{(i + 1) % count}"/>'
        for i in range(count)
    )
    path = tmp_path / "ring.ssd"
    path.write_text(
        f'<?xml version="1.0"?><ssd:SystemStructureDescription {SSP_NAMESPACES} name="s" '
        f'version="1.0"><ssd:System name="r"><ssd:Connectors>{connectors}</ssd:Connectors>'
        f"<ssd:Connections>{edges}</ssd:Connections></ssd:System>"
        "</ssd:SystemStructureDescription>",
        encoding="utf-8",
    )
    spec, found = load(path)
    assert spec is None
    assert [(c, m) for c, _, m in found] == [
        (
            "E073",
            "connections through system connectors form a cycle: c0 -> c1 -> c2 -> c3 -> "
            f"... ({count - 5} more) -> c{count - 1} -> c0",
        )
    ]
