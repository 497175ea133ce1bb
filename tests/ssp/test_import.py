"""The SSP front end: SSDs from other tools become the same SystemSpec a YAML file gives."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

import fmionnx
from fmionnx import api
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.frontends import load_system
from fmionnx.spec.model import ConnectionSpec
from tests.ssp.conftest import SSP_NAMESPACES, write_ssp


def ssd(body: str, *, version: str = "1.0", after: str = "") -> str:
    """A minimal SSD around ``body`` (the root system's content)."""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<ssd:SystemStructureDescription {SSP_NAMESPACES} name="sys" version="{version}">\n'
        f'<ssd:System name="root">\n{body}\n</ssd:System>\n{after}'
        "</ssd:SystemStructureDescription>\n"
    )


def gain(name: str, source: str = "resources/Gain.fmu", extra: str = "") -> str:
    return (
        f'<ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" '
        f'source="{source}">{extra}</ssd:Component>'
    )


def load(path: Path) -> tuple[object, list[tuple[str, int, str]]]:
    bag = DiagnosticBag()
    loaded = load_system(path, bag)
    found = [(d.code, d.span.line if d.span else 0, d.message) for d in bag.sorted()]
    return loaded.spec, found


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


def test_nested_systems_flatten_to_dotted_component_names(foreign_ssp: Path) -> None:
    spec, found = load(foreign_ssp)
    assert spec is not None, found
    assert list(spec.components) == ["integ", "gain1", "ctrl.gain2", "tail"]


def test_ssv_with_prefix_and_ssm_mapping_set_parameters(foreign_ssp: Path) -> None:
    spec, _ = load(foreign_ssp)
    assert spec.components["gain1"].parameters == {"k": 3.0}
    assert spec.components["ctrl.gain2"].parameters == {"k": 4.0}
    assert spec.components["integ"].parameters == {"u": 1.0}


def test_system_connectors_resolve_to_component_connectors_with_transforms(
    foreign_ssp: Path,
) -> None:
    spec, _ = load(foreign_ssp)
    first, through_ctrl_in, through_ctrl_out = spec.connections
    assert first == "integ.x -> gain1.u"
    assert isinstance(through_ctrl_in, ConnectionSpec)
    assert (through_ctrl_in.from_, through_ctrl_in.to) == ("gain1.y", "ctrl.gain2.u")
    assert (through_ctrl_in.factor, through_ctrl_in.offset) == (2.0, 1.0)
    assert isinstance(through_ctrl_out, ConnectionSpec)
    # km -> m through ssd:Units.
    assert (through_ctrl_out.from_, through_ctrl_out.to) == ("ctrl.gain2.y", "tail.u")
    assert (through_ctrl_out.factor, through_ctrl_out.offset) == (1000.0, 0.0)


def test_run_times_come_from_default_experiment_and_omsimulator_step(foreign_ssp: Path) -> None:
    spec, _ = load(foreign_ssp)
    assert (spec.run.start, spec.run.stop, spec.run.step) == (0.0, 1.0, 0.01)


def test_foreign_ssp_compiles_and_runs_with_expected_results(foreign_ssp: Path) -> None:
    result = api.compile_system(foreign_ssp)
    assert result.ok, result.diagnostics
    run = fmionnx.load(foreign_ssp).run(isolate="none")
    x, y1, y2 = run["integ.x"][-1], run["gain1.y"][-1], run["ctrl.gain2.y"][-1]
    assert x == pytest.approx(1.0)
    assert y1 == pytest.approx(3.0 * x)
    assert y2 == pytest.approx(4.0 * (2.0 * y1 + 1.0))


def test_unit_conversion_without_declared_unit_is_a_warning(loose) -> None:
    connectors = (
        '<ssd:Connectors><ssd:Connector name="{p}" kind="{k}"><ssc:Real unit="{u}"/>'
        "</ssd:Connector></ssd:Connectors>"
    )
    body = (
        "<ssd:Elements>"
        + gain("a", extra=connectors.format(p="y", k="output", u="mm"))
        + gain("b", extra=connectors.format(p="u", k="input", u="m"))
        + "</ssd:Elements><ssd:Connections>"
        '<ssd:Connection startElement="a" startConnector="y" endElement="b" endConnector="u"/>'
        "</ssd:Connections>"
    )
    spec, found = load(loose(ssd(body)))
    assert spec.connections == ["a.y -> b.u"]
    assert (
        "W070",
        4,
        "unit `mm` is not declared in `ssd:Units`; the units of the ports themselves decide "
        "the conversion from `mm` to `m`",
    ) in found


def test_xsd_violation_is_e070_at_its_line(loose) -> None:
    body = "<ssd:Elements>\n" + gain("a") + "\n<ssd:Bogus/>\n</ssd:Elements>"
    spec, found = load(loose(ssd(body)))
    assert spec is None
    codes = [(code, line) for code, line, _ in found]
    assert ("E070", 6) in codes
    assert "ssd:Bogus" in found[0][2]


def test_ssp_2_0_file_validates_against_the_2_0_schema(loose) -> None:
    body = f"<ssd:Elements>{gain('a')}</ssd:Elements>"
    spec, found = load(loose(ssd(body, version="2.0")))
    assert spec is not None, found
    spec, found = load(loose(ssd(body, version="3.0")))
    assert spec is None
    assert found[0][0] == "E071"


def test_signal_dictionary_is_unsupported_e071_at_its_line(loose) -> None:
    body = (
        f"<ssd:Elements>{gain('a')}</ssd:Elements>\n"
        '<ssd:SignalDictionaries><ssd:SignalDictionary name="d" source="d.ssb"/>'
        "</ssd:SignalDictionaries>"
    )
    spec, found = load(loose(ssd(body)))
    assert spec is None
    assert [(c, line) for c, line, _ in found] == [("E071", 5)]


def test_unknown_component_type_is_e071(loose) -> None:
    body = (
        '<ssd:Elements><ssd:Component name="m" type="application/x-matlab" '
        'source="resources/Gain.fmu"/></ssd:Elements>'
    )
    spec, found = load(loose(ssd(body)))
    assert spec is None
    assert found[0][0] == "E071"
    assert "application/x-onnx" in found[0][2] or "x-matlab" in found[0][2]


def test_connection_to_a_missing_element_is_e072(loose) -> None:
    body = (
        f"<ssd:Elements>{gain('a')}</ssd:Elements>\n<ssd:Connections>\n"
        '<ssd:Connection startElement="a" startConnector="y" endElement="nope" '
        'endConnector="u"/>\n</ssd:Connections>'
    )
    spec, found = load(loose(ssd(body)))
    assert spec is None
    assert [(c, line) for c, line, _ in found] == [("E072", 6)]


def test_component_source_outside_the_archive_is_refused(tmp_path: Path) -> None:
    body = f"<ssd:Elements>{gain('a', source='../../outside.fmu')}</ssd:Elements>"
    archive = write_ssp(tmp_path / "bad.ssp", {"SystemStructure.ssd": ssd(body)})
    spec, found = load(archive)
    assert spec is None
    assert found[0][0] == "E017"


def test_unknown_port_in_ssd_points_at_the_connection_line(loose) -> None:
    body = (
        f"<ssd:Elements>{gain('a')}{gain('b')}</ssd:Elements>\n<ssd:Connections>\n"
        '<ssd:Connection startElement="a" startConnector="yy" endElement="b" '
        'endConnector="u"/>\n</ssd:Connections>'
    )
    path = loose(ssd(body, after='<ssd:DefaultExperiment stopTime="1"/>'))
    result = api.compile_system(path)
    errors = [d for d in result.diagnostics if d.code == "E021"]
    assert errors, result.diagnostics
    assert errors[0].span is not None
    assert (errors[0].span.file, errors[0].span.line) == (path, 6)
    assert errors[0].hint == "did you mean `y`?"


def test_bad_parameter_points_into_the_ssv_file(tmp_path: Path, fixture_fmu) -> None:
    binding = (
        '<ssd:ParameterBindings><ssd:ParameterBinding source="resources/a.ssv"/>'
        "</ssd:ParameterBindings>"
    )
    ssv = (
        '<?xml version="1.0"?>\n<ssv:ParameterSet '
        'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
        'version="1.0" name="a">\n<ssv:Parameters>\n'
        '<ssv:Parameter name="kk"><ssv:Real value="1"/></ssv:Parameter>\n'
        "</ssv:Parameters></ssv:ParameterSet>\n"
    )
    body = f"<ssd:Elements>{gain('a', extra=binding)}</ssd:Elements>"
    archive = write_ssp(
        tmp_path / "p.ssp",
        {
            "SystemStructure.ssd": ssd(body, after='<ssd:DefaultExperiment stopTime="1"/>'),
            "resources/Gain.fmu": fixture_fmu("Gain"),
            "resources/a.ssv": ssv,
        },
    )
    result = api.compile_system(archive)
    errors = [d for d in result.diagnostics if d.code == "E042"]
    assert errors, result.diagnostics
    assert errors[0].span is not None
    assert (errors[0].span.file.name, errors[0].span.line) == ("a.ssv", 4)


def test_external_entities_are_not_expanded(loose, tmp_path: Path) -> None:
    secret = tmp_path / "secret.txt"
    secret.write_text("TOPSECRET", encoding="utf-8")
    text = (
        ssd(f"<ssd:Elements>{gain('a')}</ssd:Elements>")
        .replace(
            "<ssd:SystemStructureDescription",
            f'<!DOCTYPE x [<!ENTITY s SYSTEM "file://{secret}">]>\n<ssd:SystemStructureDescription',
            1,
        )
        .replace('name="sys"', 'name="sys&s;"')
    )
    spec, found = load(loose(text))
    assert "TOPSECRET" not in repr(spec)
    assert all("TOPSECRET" not in message for _, _, message in found)
    assert spec is None  # libxml2 refuses the unexpanded entity in an attribute (E001)


def test_an_internal_entity_is_refused_not_expanded(loose, tmp_path: Path) -> None:
    """libxml2 expanded an internal DTD's entities (`name="sys&e;"` became `sysX`) though the
    docs said no entity is expanded (a bug hunt): any DTD in an SSP file is E017."""
    text = (
        ssd(f"<ssd:Elements>{gain('a')}</ssd:Elements>")
        .replace(
            "<ssd:SystemStructureDescription",
            '<!DOCTYPE x [<!ENTITY e "X">]>\n<ssd:SystemStructureDescription',
            1,
        )
        .replace('name="sys"', 'name="sys&e;"')
    )
    spec, found = load(loose(text))
    assert spec is None
    assert len(found) == 1
    assert found[0][0] == "E017"
    assert "declares a DTD (<!DOCTYPE ...>); SSP files must not" in found[0][2]


def test_missing_ssd_in_archive_is_e072(tmp_path: Path) -> None:
    archive = write_ssp(tmp_path / "empty.ssp", {"resources/readme.txt": "x"})
    spec, found = load(archive)
    assert spec is None
    assert found[0][0] == "E072"
    assert "SystemStructure.ssd" in found[0][2]


def _onnx_and_mujoco(options: str) -> str:
    annotation = (
        '<ssd:Annotations><ssc:Annotation type="org.fmionnx">'
        f'<fx:Options xmlns:fx="https://fmionnx.dev/ssp/1">{options}</fx:Options>'
        "</ssc:Annotation></ssd:Annotations>"
    )
    return ssd(
        "<ssd:Elements>\n"
        '<ssd:Component name="det" type="application/x-onnx" source="resources/Gain.fmu">'
        f"\n{annotation}</ssd:Component>\n"
        '<ssd:Component name="world" type="application/x-mujoco+xml" '
        'source="resources/Gain.fmu"/>\n'
        "</ssd:Elements>"
    )


def test_onnx_and_mujoco_components_take_kind_and_options_from_our_annotation(loose) -> None:
    spec, found = load(loose(_onnx_and_mujoco('{"period": 0.1, "threads": 2}')))
    assert spec is not None, found
    assert spec.components["det"].kind == "onnx"
    assert (spec.components["det"].period, spec.components["det"].threads) == (0.1, 2)
    assert spec.components["world"].kind == "mujoco"


def test_unknown_option_in_annotation_is_e002_at_the_annotation(loose) -> None:
    spec, found = load(loose(_onnx_and_mujoco('{"thread": 2}')))
    assert spec is None
    assert [(c, line) for c, line, _ in found] == [("E002", 6)]


def test_annotation_that_is_not_json_is_e003(loose) -> None:
    spec, found = load(loose(_onnx_and_mujoco("period = 0.1")))
    assert spec is None
    assert [(c, line) for c, line, _ in found] == [("E003", 6)]


def test_system_parameter_connector_binds_through_connections(loose) -> None:
    body = (
        '<ssd:Connectors><ssd:Connector name="gainK" kind="parameter"/></ssd:Connectors>'
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="1.0" name="p"><ssv:Parameters>'
        '<ssv:Parameter name="gainK"><ssv:Real value="5"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        f"</ssd:ParameterBindings><ssd:Elements>{gain('a')}</ssd:Elements><ssd:Connections>"
        '<ssd:Connection startConnector="gainK" endElement="a" endConnector="k"/>'
        "</ssd:Connections>"
    )
    spec, found = load(loose(ssd(body)))
    assert spec is not None, found
    assert spec.components["a"].parameters == {"k": 5.0}
    assert spec.connections == []


def test_outer_binding_overrides_inner_binding(loose) -> None:
    inner = (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        '<ssv:ParameterSet version="1.0" name="i"><ssv:Parameters>'
        '<ssv:Parameter name="k"><ssv:Real value="1"/></ssv:Parameter>'
        "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>"
        "</ssd:ParameterBindings>"
    )
    outer = inner.replace('name="k"', 'name="a.k"').replace('value="1"', 'value="7"')
    spec, found = load(loose(ssd(f"{outer}<ssd:Elements>{gain('a', extra=inner)}</ssd:Elements>")))
    assert spec is not None, found
    assert spec.components["a"].parameters == {"k": 7.0}


#: A binding of an inline parameter set and an inline mapping onto component ``a``; line 5 of
#: the SSD holds the parameter, line 7 the mapping entry.
INLINE = (
    "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
    '<ssv:ParameterSet version="1.0" name="p"><ssv:Parameters>\n'
    '<ssv:Parameter {name}><ssv:Real value="5"/></ssv:Parameter>\n'
    "</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues>"
    '<ssd:ParameterMapping><ssm:ParameterMapping version="1.0">\n'
    '<ssm:MappingEntry source="gainK" target="a.k"><ssc:LinearTransformation {factor}/>'
    "</ssm:MappingEntry>\n</ssm:ParameterMapping></ssd:ParameterMapping>"
    f"</ssd:ParameterBinding></ssd:ParameterBindings><ssd:Elements>{gain('a')}</ssd:Elements>"
)


def test_an_inline_parameter_set_and_mapping_set_their_parameter(loose) -> None:
    spec, found = load(loose(ssd(INLINE.format(name='name="gainK"', factor='factor="2"'))))
    assert spec is not None, found
    assert spec.components["a"].parameters == {"k": 10.0}


@pytest.mark.parametrize(
    ("name", "factor", "line", "message"),
    [
        # the fuzzer's finding: a byte-order mark glued to `name` makes another attribute
        ('\ufeffname="gainK"', 'factor="2"', 5, "The attribute 'name' is required but missing"),
        ('name="gainK"', 'factor="twice"', 7, "'twice' is not a valid value"),
    ],
)
def test_inline_parameter_sets_and_mappings_follow_their_schema(
    loose, name: str, factor: str, line: int, message: str
) -> None:
    """The SSD's own schema leaves inline sets and mappings unchecked; a missing name was a
    TypeError and a factor that is not a number a ValueError, both tracebacks."""
    spec, found = load(loose(ssd(INLINE.format(name=name, factor=factor))))
    assert spec is None
    assert any(code == "E070" and at == line and message in text for code, at, text in found), found


@pytest.mark.parametrize(
    ("size", "message"),
    [
        ("0.01", None),
        ("fast", "Input should be a valid number (got 'fast')"),
        ("nan", "Input should be a finite number"),
        ("-1", "Input should be greater than 0"),
    ],
)
def test_omsimulator_step_is_checked_at_its_annotation(
    loose, size: str, message: str | None
) -> None:
    """OMSimulator's fixed step lies in its own annotation, which no schema covers: a step
    that is not a number was a ValueError traceback, and the others were reported at the
    SSD's root element."""
    annotation = (
        '<ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:Annotations>'
        "<oms:SimulationInformation>\n"
        f'<oms:FixedStepMaster description="oms-ma" stepSize="{size}"/>\n'
        "</oms:SimulationInformation></oms:Annotations></ssc:Annotation></ssd:Annotations>"
    )
    spec, found = load(loose(ssd(f"<ssd:Elements>{gain('a')}</ssd:Elements>{annotation}")))
    if message is None:
        assert spec is not None, found
        assert spec.run.step == 0.01
        return
    assert spec is None
    assert [(code, line) for code, line, _ in found] == [("E003", 5)]
    assert "`run.step`" in found[0][2]
    assert message in found[0][2]


def test_a_run_annotation_that_is_not_a_mapping_beside_an_omsimulator_step_is_e003(
    loose,
) -> None:
    step = (
        '<ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:Annotations>'
        '<oms:SimulationInformation><oms:FixedStepMaster stepSize="0.01"/>'
        "</oms:SimulationInformation></oms:Annotations></ssc:Annotation></ssd:Annotations>"
    )
    ours = (
        '<ssd:Annotations><ssc:Annotation type="org.fmionnx">'
        '<fx:Options xmlns:fx="https://fmionnx.dev/ssp/1">{"run": 5}</fx:Options>'
        "</ssc:Annotation></ssd:Annotations>\n"
    )
    spec, found = load(loose(ssd(f"<ssd:Elements>{gain('a')}</ssd:Elements>{step}", after=ours)))
    assert spec is None
    assert [(code, line) for code, line, _ in found] == [("E003", 6)]
    assert "`run` must be the run settings: a mapping (got 5)" in found[0][2]


def test_validate_and_graph_commands_read_ssp(foreign_ssp: Path) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    runner = CliRunner()
    result = runner.invoke(app, ["validate", str(foreign_ssp)])
    assert result.exit_code == 0, result.output
    assert "I070" in result.output  # its ConnectorGeometry: one note, no warning
    result = runner.invoke(app, ["graph", str(foreign_ssp), "--format", "mermaid"])
    assert result.exit_code == 0, result.output
    assert "ctrl.gain2" in result.output


def test_fmi2_element_connector_names_count_from_one(loose) -> None:
    body = (
        f"<ssd:Elements>{gain('a')}{gain('b')}</ssd:Elements>\n<ssd:Connections>\n"
        '<ssd:Connection startElement="a" startConnector="w[1]" endElement="b" '
        'endConnector="v[3]"/>\n</ssd:Connections>'
    )
    path = loose(ssd(body, after='<ssd:DefaultExperiment stopTime="1"/>'))
    spec, found = load(path)
    assert spec is not None, found
    assert spec.connections == ["a.w[0] -> b.v[2]"]
    assert api.compile_system(path).ok
    spec, found = load(loose(ssd(body.replace("w[1]", "w[0]"))))
    assert spec is None
    assert [(c, line) for c, line, _ in found] == [("E072", 6)]


def test_other_tools_annotations_are_ignored_with_one_warning_per_type(loose) -> None:
    note = (
        '<ssd:Annotations><ssc:Annotation type="com.vendor"><v:x xmlns:v="urn:v"/>'
        "</ssc:Annotation></ssd:Annotations>"
    )
    body = f"<ssd:Elements>{gain('a', extra=note)}{gain('b', extra=note)}</ssd:Elements>"
    spec, found = load(loose(ssd(body)))
    assert spec is not None
    assert [(c, m) for c, _, m in found] == [
        ("W070", "annotations of type `com.vendor` are ignored")
    ]
