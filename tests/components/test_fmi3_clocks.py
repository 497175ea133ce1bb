"""FMI 3 clocks: listed by ``inspect`` with their interval settings, E025 where a system needs
them (issue #13). fmionnx does not run FMUs in Event Mode yet.

Description-only FMUs (no binary: E015 is expected beside E025 and is not the point here).
"""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.kinds.fmu.kind import load_fmu_interface
from tests.components.fmi_xml import fmi3, fmu_folder

INPUT_CLOCK = (
    '<Clock name="tick" valueReference="5" causality="input" intervalVariability="constant" '
    'intervalDecimal="0.1" shiftDecimal="0.02" priority="1"/>'
)
OUTPUT_CLOCK = (
    '<Clock name="alarm" valueReference="6" causality="output" intervalVariability="triggered"/>'
)
PLAIN_OUTPUT = '<Float64 name="y" valueReference="7" causality="output" variability="continuous"/>'
CLOCKED_OUTPUT = (
    '<Float64 name="x" valueReference="8" causality="output" variability="discrete" clocks="5"/>'
)

SYSTEM = """\
fmionnx: 1
name: clocks
run: {{stop: 0.1, step: 0.01}}
components:
  m: {{kind: fmu, path: M}}
  n: {{kind: fmu, path: M}}
connections:
  - {connection}
"""


def _fmu(tmp_path: Path, variables: list[str], structure: str) -> Path:
    return fmu_folder(tmp_path, "M", fmi3(variables, structure))


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def test_inspect_lists_clocks_with_their_interval_settings(tmp_path: Path) -> None:
    folder = _fmu(
        tmp_path,
        [INPUT_CLOCK, OUTPUT_CLOCK, PLAIN_OUTPUT],
        '<Output valueReference="6"/><Output valueReference="7"/>'
        '<InitialUnknown valueReference="7"/>',
    )
    code, output = _cli("inspect", str(folder))
    assert code == 0, output
    assert "unsupported.tick" in output
    assert "FMI 3 clock (input), interval constant 0.1 s, shift 0.02 s, priority 1" in output
    assert "FMI 3 clock (output), interval triggered" in output
    result = CliRunner().invoke(app, ["inspect", str(folder), "--format", "json"])
    data = json.loads(result.stdout)
    facts = data["facts"] if isinstance(data["facts"], dict) else dict(data["facts"])
    assert facts["unsupported.alarm"] == "FMI 3 clock (output), interval triggered"
    assert [p["name"] for p in data["ports"]] == ["y"]  # clocks are not ports


def test_a_model_with_an_input_clock_is_e025(tmp_path: Path) -> None:
    _fmu(
        tmp_path,
        [INPUT_CLOCK, PLAIN_OUTPUT],
        '<Output valueReference="7"/><InitialUnknown valueReference="7"/>',
    )
    system = tmp_path / "system.yaml"
    system.write_text(SYSTEM.format(connection="m.y -> n.y"), encoding="utf-8")
    code, output = _cli("validate", str(system))
    assert code == 1
    assert "E025" in output
    assert "input clock `tick`" in output
    assert "system.yaml:5:" in output  # at the component's path
    assert "Traceback" not in output


def test_clocked_ports_are_e025(tmp_path: Path) -> None:
    _fmu(
        tmp_path,
        [OUTPUT_CLOCK, CLOCKED_OUTPUT.replace('clocks="5"', 'clocks="6"')],
        '<Output valueReference="6"/><Output valueReference="8"/>',
    )
    assert load_fmu_interface(tmp_path / "M").fact("clockedVariables") == "x"
    system = tmp_path / "system.yaml"
    system.write_text(SYSTEM.format(connection="m.x -> n.x"), encoding="utf-8")
    code, output = _cli("validate", str(system))
    assert code == 1
    assert "E025" in output
    assert "`x` change only when a clock ticks" in output


def test_an_endpoint_naming_a_clock_is_e025_not_an_unknown_port(tmp_path: Path) -> None:
    _fmu(
        tmp_path,
        [OUTPUT_CLOCK, PLAIN_OUTPUT],
        '<Output valueReference="6"/><Output valueReference="7"/>'
        '<InitialUnknown valueReference="7"/>',
    )
    system = tmp_path / "system.yaml"
    system.write_text(SYSTEM.format(connection="m.alarm -> n.y"), encoding="utf-8")
    code, output = _cli("validate", str(system))
    assert code == 1
    assert "E025" in output
    assert "`m.alarm` is not supported yet: it is an FMI 3 clock (output)" in output
    assert "system.yaml:8:" in output
    assert "E021" not in output
    assert "clock (input)" not in output  # an output clock alone does not refuse the model
