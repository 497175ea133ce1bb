"""``fmionnx lsp`` driven over stdio by a real LSP client, as an editor drives it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from lsprotocol import types
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import REPO
from tests.lsp.client import Session, apply
from tests.lsp.conftest import reference_text

TYPO = reference_text().replace(
    "  - odometry.theta -> tracker.theta", "  - odometry.thta -> tracker.theta"
)


def _write(workspace: Path, name: str, text: str) -> Path:
    path = workspace / "systems" / name
    path.write_text(text, encoding="utf-8")
    return path


def _position(text: str, line_part: str, inside: str, offset: int = 0) -> tuple[int, int]:
    """0-based line and column of ``inside`` (plus ``offset``) on the line holding ``line_part``."""
    for number, line in enumerate(text.split("\n")):
        if line_part in line:
            return number, line.index(inside) + offset
    raise AssertionError(line_part)


def _validate_json(path: Path) -> list[dict[str, object]]:
    """What ``fmionnx validate --format json`` reports for ``path``."""
    import fmionnx.cli  # noqa: F401 - registers the commands

    result = CliRunner().invoke(app, ["validate", "--format", "json", str(path)])
    report = json.loads(result.output)
    return [d for f in report["files"] for d in f["diagnostics"]]


def test_initialize_announces_what_the_server_does(server: Session) -> None:
    result = server.initialize()
    capabilities = result.capabilities
    assert result.server_info is not None
    assert result.server_info.name == "fmionnx"
    assert capabilities.completion_provider is not None
    assert "." in (capabilities.completion_provider.trigger_characters or [])
    assert capabilities.hover_provider
    assert capabilities.definition_provider
    assert capabilities.code_action_provider
    assert capabilities.rename_provider


def test_a_port_typo_gets_validates_code_range_and_hint(server: Session, workspace: Path) -> None:
    path = _write(workspace, "typo.yaml", TYPO)
    expected = _validate_json(path)
    uri = server.open(path)
    found = server.wait_diagnostics(uri)
    assert [d.code for d in found] == [d["code"] for d in expected] == ["E021"]
    diagnostic, reported = found[0], expected[0]
    # validate's position is 1-based, the protocol's 0-based; the range covers the endpoint
    assert (diagnostic.range.start.line + 1, diagnostic.range.start.character + 1) == (
        reported["line"],
        reported["col"],
    )
    line, column = _position(TYPO, "odometry.thta ->", "odometry.thta")
    assert diagnostic.range.start == types.Position(line=line, character=column)
    assert diagnostic.range.end == types.Position(
        line=line, character=column + len("odometry.thta")
    )
    assert diagnostic.message.splitlines()[0] == reported["message"]
    assert f"hint: {reported['hint']}" in diagnostic.message
    assert diagnostic.severity == types.DiagnosticSeverity.Error
    assert diagnostic.source == "fmionnx"
    # the note "ports are read from ReadOdometry.fmu" points into its model description
    related = diagnostic.related_information or []
    assert [r.location.uri.endswith("ReadOdometry.fmu/modelDescription.xml") for r in related] == [
        True
    ]


def test_an_edit_is_checked_again(server: Session, workspace: Path) -> None:
    path = _write(workspace, "edited.yaml", reference_text())
    uri = server.open(path)
    assert server.wait_diagnostics(uri) == []
    server.change(uri, TYPO)
    assert [d.code for d in server.wait_diagnostics(uri)] == ["E021"]
    server.change(uri, reference_text())
    assert server.wait_diagnostics(uri) == []


def test_completion_after_detector_lists_its_outputs_with_shapes(
    server: Session, workspace: Path
) -> None:
    text = reference_text().replace("  - detector.blobX -> tracker.blobX", "  - detector.")
    path = _write(workspace, "complete.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "  - detector.", "detector.", len("detector."))
    items = {i.label: i for i in server.completion(uri, line, column)}
    assert set(items) == {"blobX", "blobSize"}  # outputs only: `image` is the model's input
    assert items["blobX"].detail == "output float32[1,3]"
    assert items["blobSize"].detail == "output float32[1,3]"
    edit = items["blobX"].text_edit
    assert isinstance(edit, types.TextEdit)
    assert edit.range.start == edit.range.end == types.Position(line=line, character=column)


def test_completion_right_of_the_arrow_lists_inputs(server: Session, workspace: Path) -> None:
    text = reference_text().replace(
        "  - detector.blobX -> tracker.blobX", "  - detector.blobX -> tracker.bl"
    )
    path = _write(workspace, "complete_right.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "-> tracker.bl", "tracker.bl", len("tracker.bl"))
    items = {i.label: i for i in server.completion(uri, line, column)}
    assert set(items) == {"blobX", "blobSize", "posX", "posY", "theta"}
    # neither outputs (`v`) nor parameters (`turnRate`, set under `parameters:`) go there
    assert items["theta"].detail == "input float64 rad"
    edit = items["blobX"].text_edit
    assert isinstance(edit, types.TextEdit)
    assert edit.range.start == types.Position(line=line, character=column - len("bl"))


def test_completion_of_parameters_and_component_names(server: Session, workspace: Path) -> None:
    text = reference_text()
    path = _write(workspace, "complete_keys.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "parameters: {turnRate", "turnRate")
    parameters = {i.label: i for i in server.completion(uri, line, column)}
    assert {"turnRate", "cruiseSpeed", "turnGain"} <= set(parameters)
    assert parameters["turnRate"].detail == "parameter float64 rad/s"
    line, column = _position(text, "  - tracker.v -> world.cmd_v", "tracker")
    names = {i.label for i in server.completion(uri, line, column)}
    assert names == {"world", "odometry", "detector", "tracker"}
    # ROS 2: the members of the message type the entry names, at the field path typed so far
    line, column = _position(text, "tracker.w: {topic: /cmd_vel", "angular.", len("angular."))
    fields = {i.label: i.detail for i in server.completion(uri, line, column)}
    assert fields == {"x": "scalar float64", "y": "scalar float64", "z": "scalar float64"}


def test_completion_of_a_kind_and_the_keys_it_takes(server: Session, workspace: Path) -> None:
    text = reference_text().replace(
        "    period: 0.01\n    description: Planar", "    \n    description: Planar", 1
    )
    uri = server.open(_write(workspace, "complete_kind.yaml", text))
    line = next(n for n, row in enumerate(text.split("\n")) if row == "    ")
    keys = {i.label: i for i in server.completion(uri, line, 4)}
    # an FMU entry's keys the file does not give yet, with what each means
    assert {"period", "interface", "solver", "tolerance", "external"} <= set(keys)
    assert not {"kind", "path", "cameras", "providers"} & set(keys)
    documentation = keys["interface"].documentation
    assert isinstance(documentation, types.MarkupContent)
    assert "co-simulation" in documentation.value
    line, column = _position(text, "    kind: onnx", "onnx")
    items = {i.label: i for i in server.completion(uri, line, column)}
    assert set(items) == {"fmu", "onnx", "mujoco", "signal"}
    assert items["mujoco"].detail == "MuJoCo physics scene (sensors, actuators, cameras)"
    edit = items["fmu"].text_edit  # the kind the cursor is in is replaced, not pushed aside
    assert isinstance(edit, types.TextEdit)
    assert (edit.range.start.character, edit.range.end.character) == (column, column + len("onnx"))


def test_hover_on_odometry_theta_shows_its_unit(server: Session, workspace: Path) -> None:
    text = reference_text()
    path = _write(workspace, "hover.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "  - odometry.theta -> tracker.theta", "odometry.theta", 10)
    found = server.hover(uri, line, column)
    assert found is not None
    assert isinstance(found.contents, types.MarkupContent)
    shown = found.contents.value
    assert "**odometry.theta**" in shown
    assert "unit `rad`" in shown
    assert "output `float64` scalar" in shown
    assert "ReadOdometry.fmu/modelDescription.xml:" in shown


def test_definition_of_a_port_lands_in_its_model_description(
    server: Session, workspace: Path
) -> None:
    text = reference_text()
    path = _write(workspace, "definition.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "  - odometry.theta -> tracker.theta", "odometry.theta", 10)
    [location] = server.definition(uri, line, column)
    assert location.uri.endswith("/modelDescription.xml")
    xml = Path(location.uri.removeprefix("file://")).read_text(encoding="utf-8").splitlines()
    assert 'name="theta"' in xml[location.range.start.line]
    # a MuJoCo port: its element in the scene's XML; a site: its <site>
    line, column = _position(text, "  - world.base_pos[0] -> odometry.x", "base_pos")
    [scene] = server.definition(uri, line, column)
    assert scene.uri == (workspace / "models" / "world" / "sign_course.xml").as_uri()
    xml = (REPO / "models" / "world" / "sign_course.xml").read_text(encoding="utf-8").splitlines()
    assert 'name="base_pos"' in xml[scene.range.start.line]
    line, column = _position(text, "to=world.site.B", "site.B", 5)
    [site] = server.definition(uri, line, column)
    assert '<site name="B"' in xml[site.range.start.line]
    # an ONNX output: its line on the model's page
    line, column = _position(text, "  - detector.blobX -> tracker.blobX", "blobX")
    [page] = server.definition(uri, line, column)
    assert page.uri.endswith("/sign_detector.onnx.txt")
    shown = Path(page.uri.removeprefix("file://")).read_text(encoding="utf-8").splitlines()
    assert shown[page.range.start.line].startswith("  blobX: float32[1,3]  # Mean 0-based column")


def test_a_code_action_fixes_the_typo(server: Session, workspace: Path) -> None:
    path = _write(workspace, "fix.yaml", TYPO)
    uri = server.open(path)
    [diagnostic] = server.wait_diagnostics(uri)
    explained = server.hover(uri, diagnostic.range.start.line, diagnostic.range.start.character)
    assert explained is not None
    assert isinstance(explained.contents, types.MarkupContent)
    assert "**E021** `unknown-port` (error, endpoint): A connection names a port" in (
        explained.contents.value
    )
    actions = server.code_actions(uri, diagnostic.range, [diagnostic])
    titles = [a.title for a in actions]
    assert titles == ["Replace `thta` with `theta`"]
    edit = actions[0].edit
    assert edit is not None
    assert edit.changes is not None
    fixed = apply(TYPO, edit.changes[uri])
    assert fixed == reference_text()
    server.change(uri, fixed)
    assert server.wait_diagnostics(uri) == []


def test_a_malformed_file_gets_diagnostics_and_the_server_still_answers(
    server: Session, workspace: Path
) -> None:
    broken = "fmionnx: 1\nname: broken\ncomponents: {a: [1, 2\nconnections:\n  - a.y -> \n"
    path = _write(workspace, "broken.yaml", broken)
    uri = server.open(path)
    found = server.wait_diagnostics(uri)
    assert [d.code for d in found] == ["E001"]
    assert found[0].message.startswith("invalid YAML")
    assert server.hover(uri, 2, 14) is None
    assert server.completion(uri, 4, 11) == []
    assert server.definition(uri, 4, 5) == []
    # control characters, a tab for indentation, brackets that close nothing
    garbage = _write(workspace, "garbage.yaml", "fmionnx: 1\n\x00\x01 {]: ::\n\t- [\n")
    assert [d.code for d in server.wait_diagnostics(server.open(garbage))] == ["E001"]
    # still the same, working process
    assert server.process.returncode is None
    good = _write(workspace, "after_broken.yaml", TYPO)
    assert [d.code for d in server.wait_diagnostics(server.open(good))] == ["E021"]
    assert not any("internal error" in line for line in server.log)


def test_a_yaml_file_that_is_not_fmionnx_s_is_left_alone(server: Session, workspace: Path) -> None:
    workflow = "name: CI\non: [push]\njobs:\n  test: {runs-on: ubuntu-latest}\n"
    uri = server.open(_write(workspace, "workflow.yaml", workflow))
    assert server.wait_diagnostics(uri) == []
    assert server.completion(uri, 3, 2) == []


def test_a_model_that_crashes_when_loaded_is_reported_not_loaded(
    server: Session, workspace: Path, fixture_fmu
) -> None:
    crashing = fixture_fmu("CrashOnLoad")
    system = (
        "fmionnx: 1\nname: crash\nrun: {stop: 1, step: 0.01}\n"
        f"components:\n  bad: {{kind: fmu, path: {crashing}}}\n"
        "  src: {kind: signal, outputs: {a: {constant: 1}}}\n"
        "connections:\n  - src.a -> bad.uu\n"
    )
    path = _write(workspace, "crash.yaml", system)
    uri = server.open(path)
    found = {d.code: d for d in server.wait_diagnostics(uri)}
    assert set(found) == {"E021", "W030"}  # `bad.u` is not connected: the typo
    assert "did you mean `u`?" in found["E021"].message
    items = {i.label for i in server.completion(uri, 7, len("  - src.a -> bad."))}
    assert items == {"u"}
    assert server.process.returncode is None


def test_a_study_completes_its_targets_from_the_system(server: Session, workspace: Path) -> None:
    _write(workspace, "studied.yaml", reference_text())
    study = (
        "fmionnx: 1\nsystem: studied.yaml\nparameters:\n  tracker.turnRat: [0.4, 1.2]\n"
        "metrics:\n  d: final(odometry.posX)\n"
    )
    path = _write(workspace, "study.yaml", study)
    uri = server.open(path)
    found = server.wait_diagnostics(uri)
    assert [d.code for d in found] == ["E102"]
    assert found[0].range.start.line == 3
    items = {i.label for i in server.completion(uri, 3, len("  tracker."))}
    assert {"turnRate", "cruiseSpeed"} <= items
    assert "v" not in items  # an output is no target
    metric = {i.label: i.detail for i in server.completion(uri, 5, len("  d: final(odometry."))}
    assert metric["posX"] == "output float64 m"
    # the study's system is one definition away
    [location] = server.definition(uri, 1, len("system: stu"))
    assert location.uri == (workspace / "systems" / "studied.yaml").as_uri()


def test_rename_of_a_component_edits_every_reference(server: Session, workspace: Path) -> None:
    text = reference_text()
    path = _write(workspace, "rename.yaml", text)
    uri = server.open(path)
    line, column = _position(text, "  - odometry.theta -> tracker.theta", "odometry", 2)
    edit = server.rename(uri, line, column, "odo")
    assert edit is not None
    assert edit.changes is not None
    renamed = apply(text, edit.changes[uri])
    assert "odometry." not in renamed
    assert renamed.count("odo.") == text.count("odometry.")
    assert "odometry FMU" in renamed  # free text stays as written
    assert "  odo:\n" in renamed
    assert "    odo: fmu_odometry_node" in renamed
    server.change(uri, renamed)
    assert server.wait_diagnostics(uri) == []


def test_unit_mismatches_get_the_long_form_fixes(
    server: Session, workspace: Path, fixture_fmu
) -> None:
    gain = fixture_fmu("Gain")
    system = (
        "fmionnx: 1\nname: units\nrun: {stop: 1, step: 0.01}\ncomponents:\n"
        "  src: {kind: signal, outputs: {a: {constant: 1, unit: px}, b: {constant: 1, unit: s}}}\n"
        f"  gain: {{kind: fmu, path: {gain}}}\n"
        "connections:\n  - src.a -> gain.u\n  - src.b -> gain.v[0]\n"
    )
    path = _write(workspace, "units.yaml", system)
    uri = server.open(path)
    found = server.wait_diagnostics(uri)
    units = {
        i.label: i.detail for i in server.completion(uri, 4, system.split("\n")[4].index("px"))
    }
    assert units["km/h"] == "0.277778 m*s^-1"  # a unit and what it is in SI
    assert units["degC"] == "K + 273.15"
    assert [(d.code, d.range.start.line) for d in found if d.code == "E033"] == [
        ("E033", 7),
        ("E033", 8),
    ]
    undefined = next(d for d in found if d.range.start.line == 7)
    [factor] = server.code_actions(uri, undefined.range, [undefined])
    assert factor.edit is not None
    assert factor.edit.changes is not None
    assert factor.title == "Convert with a factor and offset (long form)"
    fixed = apply(system, factor.edit.changes[uri])
    assert "  - {from: src.a, to: gain.u, factor: 1.0, offset: 0.0}\n" in fixed
    # a factor of 1 is no conversion yet: the user writes theirs (1 px is 2 m, here)
    fixed = fixed.replace("factor: 1.0", "factor: 2.0")
    quantity = next(d for d in found if d.range.start.line == 8)
    [unconverted] = server.code_actions(uri, quantity.range, [quantity])
    assert unconverted.edit is not None
    assert unconverted.edit.changes is not None
    fixed = apply(fixed, unconverted.edit.changes[uri])
    assert "  - {from: src.b, to: 'gain.v[0]', convert_units: false}\n" in fixed
    server.change(uri, fixed)
    codes = [d.code for d in server.wait_diagnostics(uri)]
    assert "E033" not in codes
    assert "W033" in codes  # different quantities passed as they are: said, not refused


def test_an_endpoint_with_an_index_in_a_flow_list_gets_quoted(
    server: Session, workspace: Path
) -> None:
    text = reference_text().replace(
        "  - {xy: [odometry.posX, odometry.posY]", "  - {xy: [world.base_pos[0], odometry.posY]"
    )
    path = _write(workspace, "quote.yaml", text)
    uri = server.open(path)
    [diagnostic] = server.wait_diagnostics(uri)
    assert diagnostic.code == "E001"
    [action] = server.code_actions(uri, diagnostic.range, [diagnostic])
    assert action.title == "Quote `world.base_pos[0]`"
    assert action.edit is not None
    assert action.edit.changes is not None
    fixed = apply(text, action.edit.changes[uri])
    assert "  - {xy: ['world.base_pos[0]', odometry.posY]" in fixed
    server.change(uri, fixed)
    assert [d.code for d in server.wait_diagnostics(uri)] == []


def test_an_ssd_file_gets_validates_diagnostics_as_it_is_edited(
    server: Session, workspace: Path
) -> None:
    vendor = REPO / "examples" / "ssp-roundtrip" / "vendor"
    folder = workspace / "ssd"
    shutil.copytree(vendor, folder)
    path = folder / "SystemStructure.ssd"
    expected = _validate_json(path)
    uri = server.open(path)
    found = server.wait_diagnostics(uri)
    assert [(d.code, d.range.start.line + 1) for d in found] == [
        (d["code"], d["line"]) for d in expected
    ]
    assert [d.code for d in found] == ["E072", "I070", "E072"]
    text = path.read_text(encoding="utf-8")
    server.change(uri, text.replace("<ssd:Elements>", "<ssd:Elements", 1))
    [broken] = server.wait_diagnostics(uri)
    assert broken.code == "E001"
    assert "is not well-formed XML" in broken.message
    server.change(uri, text)
    assert [d.code for d in server.wait_diagnostics(uri)] == ["E072", "I070", "E072"]


def test_a_note_naming_a_declaration_is_related_information_at_its_line(
    server: Session, workspace: Path
) -> None:
    text = reference_text().replace(
        "  - odometry.theta -> tracker.theta", "  - odometry.posX -> tracker.theta"
    )
    path = _write(workspace, "declared.yaml", text)
    uri = server.open(path)
    [diagnostic] = server.wait_diagnostics(uri)
    assert diagnostic.code == "E033"  # m into rad
    [related] = diagnostic.related_information or []
    assert (
        related.message
        == "`theta` is declared at SignTrackingLogic.fmu/modelDescription.xml:"
        + (related.message.rsplit(":", 1)[1])
    )
    assert related.location.uri.endswith("SignTrackingLogic.fmu/modelDescription.xml")
    xml = Path(related.location.uri.removeprefix("file://")).read_text(encoding="utf-8")
    line = xml.splitlines()[related.location.range.start.line]
    assert 'name="theta"' in line
    assert str(related.location.range.start.line + 1) == related.message.rsplit(":", 1)[1]


def test_a_model_rebuilt_on_disk_is_read_again_when_the_editor_says_so(
    server: Session, workspace: Path, fixture_fmu
) -> None:
    model = workspace / "systems" / "watched.fmu"
    shutil.copy(fixture_fmu("Gain"), model)
    system = (
        "fmionnx: 1\nname: watched\nrun: {stop: 1, step: 0.01}\n"
        "components:\n  g: {kind: fmu, path: watched.fmu}\n"
        "  src: {kind: signal, outputs: {a: {constant: 1}}}\n"
        "connections:\n  - src.a -> g.v[0]\n"
    )
    uri = server.open(_write(workspace, "watched.yaml", system))
    assert "E021" not in [d.code for d in server.wait_diagnostics(uri)]
    shutil.copy(fixture_fmu("Integrator"), model)  # rebuilt: another model, no `v`
    server.files_changed(model)
    assert "E021" in [d.code for d in server.wait_diagnostics(uri)]


SSD = """\
<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    name="pair" version="1.0">
  <ssd:System name="root">
    <ssd:Elements>
      <ssd:Component name="integ" type="application/x-fmu-sharedlibrary" source="Integrator.fmu">
        <ssd:Connectors>
          <ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
      <ssd:Component name="gain" type="application/x-fmu-sharedlibrary" source="Gain.fmu">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="input"><ssc:Real unit="m"/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="integ" startConnector="x" endElement="gain" endConnector="u"/>
    </ssd:Connections>
  </ssd:System>
</ssd:SystemStructureDescription>
"""


def test_an_ssd_completes_hovers_and_goes_to_its_models(
    server: Session, workspace: Path, fixture_fmu
) -> None:
    folder = workspace / "pair"
    folder.mkdir()
    for name in ("Integrator", "Gain"):
        shutil.copy(fixture_fmu(name), folder / f"{name}.fmu")
    path = folder / "pair.ssd"
    path.write_text(SSD, encoding="utf-8")
    uri = server.open(path)
    assert "E021" not in [d.code for d in server.wait_diagnostics(uri)]
    line, column = _position(SSD, "endConnector=", 'endConnector="', len('endConnector="'))
    inputs = {i.label: i.detail for i in server.completion(uri, line, column)}
    assert inputs["u"] == "input float64 m"
    assert "y" not in inputs  # an output does not end a connection
    line, column = _position(SSD, "startConnector=", 'startConnector="', len('startConnector="'))
    assert {i.label for i in server.completion(uri, line, column)} == {"x"}
    found = server.hover(uri, line, column)
    assert found is not None
    assert isinstance(found.contents, types.MarkupContent)
    assert found.contents.value.startswith("**integ.x** — output `float64` scalar")
    [location] = server.definition(uri, line, column)
    assert location.uri.endswith("Integrator.fmu/modelDescription.xml")
    xml = Path(location.uri.removeprefix("file://")).read_text(encoding="utf-8").splitlines()
    assert 'name="x"' in xml[location.range.start.line]
    # a misspelt connector: the compiler's diagnostic, as validate gives it
    typo = SSD.replace('endConnector="u"', 'endConnector="uu"')
    server.change(uri, typo)
    [diagnostic] = [d for d in server.wait_diagnostics(uri) if d.code == "E021"]
    assert diagnostic.range.start.line == _position(typo, 'endConnector="uu"', "<")[0]
    [action] = server.code_actions(uri, diagnostic.range, [diagnostic])
    assert action.title == "Replace `uu` with `u`"
    assert action.edit is not None
    assert action.edit.changes is not None
    assert apply(typo, action.edit.changes[uri]) == SSD


def test_a_request_on_a_file_neither_open_nor_readable_is_refused_in_one_line(
    server: Session, workspace: Path
) -> None:
    """A hover on a never-opened file that is gone was an "internal error" and a traceback
    (a bug hunt): the client gets an error answer naming the file, the server logs no bug."""
    uri = (workspace / "systems" / "never-there.yaml").as_uri()
    for ask in (server.hover, server.definition):
        with pytest.raises(Exception, match="is not open in the editor and cannot be read") as got:
            ask(uri, 0, 0)
        assert "never-there.yaml" in str(got.value)
    assert not [m for m in server.log if "internal error" in m]
    assert "Traceback" not in server.stderr_text()
