"""SSP run settings (issue 13): a step when the SSD gives none, command-line run settings, and
the diagram layout noted once instead of warned about element by element."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

import fmionnx
from fmionnx import api
from fmionnx.cli.app import app
from fmionnx.compile.ir import Origin
from tests.ssp.conftest import SSP_NAMESPACES

LAYOUT = '<ssd:ConnectorGeometry x="0" y="0.5"/>'


def _signal_ssd(tmp_path: Path, *, experiment: str, geometry: bool = False) -> Path:
    """A loose SSD with one signal component (no model file, so no default experiment)."""
    element = '<ssd:ElementGeometry x1="0" y1="0" x2="10" y2="10"/>' if geometry else ""
    connector = LAYOUT if geometry else ""
    text = f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription {SSP_NAMESPACES} name="sig" version="1.0">
  <ssd:System name="root">
    <ssd:Elements>
      <ssd:Component name="src" type="application/x-fmionnx-signal" source="">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="output"><ssc:Real/>{connector}</ssd:Connector>
          <ssd:Connector name="v" kind="output"><ssc:Real/>{connector}</ssd:Connector>
        </ssd:Connectors>
        {element}
        <ssd:Annotations><ssc:Annotation type="org.fmionnx">
          <fx:Options xmlns:fx="https://fmionnx.dev/ssp/1">{{"outputs": {{"u": {{"constant": 1}}, "v": {{"constant": 2}}}}}}</fx:Options>
        </ssc:Annotation></ssd:Annotations>
      </ssd:Component>
    </ssd:Elements>
    {'<ssd:SystemGeometry x1="0" y1="0" x2="1" y2="1"/>' if geometry else ""}
  </ssd:System>
  {experiment}
</ssd:SystemStructureDescription>
"""
    path = tmp_path / "system.ssd"
    path.write_text(text, encoding="utf-8")
    return path


def test_an_ssd_without_any_step_gets_the_documented_default(tmp_path: Path) -> None:
    path = _signal_ssd(tmp_path, experiment='<ssd:DefaultExperiment stopTime="10"/>')
    run = fmionnx.load(path).compiled.run
    assert (run.step, run.steps) == (0.01, 1000)
    assert ("step", Origin.BUILTIN_DEFAULT) in run.origins
    # 32 s: the smallest 1-2-5 step giving at most 1000 steps
    path = _signal_ssd(tmp_path, experiment='<ssd:DefaultExperiment stopTime="32"/>')
    assert fmionnx.load(path).compiled.run.step == 0.05


def test_a_yaml_file_without_a_step_is_still_e004(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(
        "fmionnx: 1\nname: s\nrun: {stop: 10}\n"
        "components:\n  src: {kind: signal, outputs: {u: {constant: 1}}}\n",
        encoding="utf-8",
    )
    codes = [d.code for d in api.compile_system(path).diagnostics]
    assert "E004" in codes


def test_step_and_start_time_on_the_command_line_apply_to_an_ssd(tmp_path: Path) -> None:
    path = _signal_ssd(tmp_path, experiment='<ssd:DefaultExperiment stopTime="1"/>')
    out = tmp_path / "out"
    args = ["run", str(path), "--out", str(out), "--step", "0.25", "--start-time", "0.5"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert (info["start_time"], info["step"], info["steps"]) == (0.5, 0.25, 2)
    assert info["settings_origin"]["step"] == "command line"
    assert info["settings_origin"]["start"] == "command line"


def test_a_bad_step_on_the_command_line_is_a_diagnostic_not_a_traceback(tmp_path: Path) -> None:
    path = _signal_ssd(tmp_path, experiment='<ssd:DefaultExperiment stopTime="1"/>')
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "--step", "0.3"])
    assert result.exit_code == 1
    assert "E040" in result.output
    assert "Traceback" not in result.output


def test_diagram_layout_is_one_note_not_a_warning_per_element(tmp_path: Path) -> None:
    path = _signal_ssd(tmp_path, experiment='<ssd:DefaultExperiment stopTime="1"/>', geometry=True)
    found = [(d.code, d.message) for d in api.compile_system(path).diagnostics]
    assert [code for code, _ in found] == ["I070"]
    assert "4 elements" in found[0][1]
    assert "`ConnectorGeometry`, `ElementGeometry`, `SystemGeometry`" in found[0][1]


def test_output_interval_travels_through_an_exported_ssp(tmp_path: Path) -> None:
    system = tmp_path / "s.yaml"
    system.write_text(
        "fmionnx: 1\nname: s\nrun: {stop: 1, step: 0.01, output_interval: 0.1}\n"
        "components:\n  src: {kind: signal, outputs: {u: {constant: 1}}}\n",
        encoding="utf-8",
    )
    archive = tmp_path / "s.ssp"
    result = CliRunner().invoke(app, ["export", str(system), "-o", str(archive)])
    assert result.exit_code == 0, result.output
    run = fmionnx.load(archive).compiled.run
    assert (run.step, run.output_interval, run.output_every) == (0.01, 0.1, 10)
