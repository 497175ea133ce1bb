"""``fmionnx node`` refuses a run that would never end, as ``fmionnx run`` does."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from fmionnx.cli import app

SYSTEM = """
fmionnx: 1
name: long
run: {{stop: 1000, step: 0.001}}
components:
  gain: {{kind: fmu, path: {gain}}}
"""


def _system(fixture_fmu, tmp_path: Path) -> Path:
    path = tmp_path / "long.yaml"
    path.write_text(SYSTEM.format(gain=fixture_fmu("Gain")), encoding="utf-8")
    return path


def test_node_refuses_more_steps_than_max_steps(fixture_fmu, tmp_path: Path) -> None:
    system = _system(fixture_fmu, tmp_path)
    result = CliRunner().invoke(app, ["node", str(system), "gain", "--max-steps", "1000"])
    assert result.exit_code == 2, result.output
    assert "the run is 1e+06 base steps, more than --max-steps 1e+03" in result.output


def test_node_max_steps_must_be_positive(fixture_fmu, tmp_path: Path) -> None:
    system = _system(fixture_fmu, tmp_path)
    result = CliRunner().invoke(app, ["node", str(system), "gain", "--max-steps", "0"])
    assert result.exit_code == 2
    assert "--max-steps must be at least 1" in result.output
