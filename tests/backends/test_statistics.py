"""Per-component statistics (``--profile``): steps, phases, shares, within the loop's time.

Real FMUs from our C sources (Gain, Integrator, Faulty as a feedthrough) and, for render
and infer, the reference scenario's MuJoCo scene and ONNX detector.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.runtime.profile import PHASES
from fmionnx.runtime.result import RunStatus

REPO = Path(__file__).resolve().parents[2]


def _chain(fixture_fmu, write_system) -> Path:
    return write_system(
        f"""
fmionnx: 1
name: chain
run: {{stop: 2.0, step: 0.001}}
components:
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}}}
  slow: {{kind: fmu, path: {fixture_fmu("Gain")}, period: 0.01}}
  integrator: {{kind: fmu, path: {fixture_fmu("Integrator")}}}
connections:
  - gain.y -> integrator.u
  - integrator.x -> slow.u
"""
    )


def test_the_phases_add_up_within_the_loop_wall_time(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_chain(fixture_fmu, write_system))
    result = system.run(isolate="none", schedule="sequential", profile=True)
    assert result.status is RunStatus.COMPLETED
    stats = result.statistics
    assert stats is not None
    wall = stats["loop_wall_time"]
    assert isinstance(wall, float)
    assert 0 < wall <= result.wall_time + 1e-6
    assert stats["concurrent"] is False
    components = stats["components"]
    assert isinstance(components, dict)
    in_loop = sum(entry["loop_time"] for entry in components.values())  # type: ignore[index]
    assert 0 < in_loop <= wall
    other = stats["other"]
    assert isinstance(other, dict)
    assert in_loop + other["loop"] == pytest.approx(wall, abs=1e-5)  # type: ignore[operator]
    shares = [entry["share"] for entry in components.values()]  # type: ignore[index]
    assert sum(shares) <= 1.0 + 1e-3  # type: ignore[arg-type]
    assert shares == sorted(shares, reverse=True)  # by share


def test_each_component_counts_its_steps_and_phases(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_chain(fixture_fmu, write_system))
    result = system.run(isolate="none", schedule="sequential", profile=True)
    stats = result.statistics
    assert stats is not None
    components = stats["components"]
    assert isinstance(components, dict)
    names = set(components)
    # gain and integrator run every base step, as one native group; slow every 10th
    group = next(n for n in names if "+" in n) if any("+" in n for n in names) else None
    steps = {n: e["steps"] for n, e in components.items()}  # type: ignore[index]
    assert steps["slow"] == 200
    if group is not None:  # the native kernel: one entry for its members
        assert steps[group] == 2000
        assert components[group]["members"] == "gain, integrator"  # type: ignore[index]
    else:
        assert steps["gain"] == steps["integrator"] == 2000
    slow = components["slow"]
    assert isinstance(slow, dict)
    phases = slow["phases"]
    assert isinstance(phases, dict)
    assert set(phases) == set(PHASES)
    assert phases["instantiate"] > 0  # type: ignore[operator]
    assert phases["initialize"] > 0  # type: ignore[operator]
    assert phases["step"] > 0  # type: ignore[operator]
    assert slow["step_max"] >= slow["step_mean"] > 0  # type: ignore[operator]


def test_without_profile_there_are_no_statistics(fixture_fmu, write_system) -> None:
    result = fmionnx.load(_chain(fixture_fmu, write_system)).run(isolate="none")
    assert result.statistics is None


@pytest.mark.slow
def test_render_and_infer_are_named_for_the_reference_scenario() -> None:
    system = fmionnx.load(REPO / "systems" / "sign_follower.yaml")
    result = system.run(stop_time=0.5, profile=True, schedule="sequential", checks=False)
    stats = result.statistics
    assert stats is not None
    components = stats["components"]
    assert isinstance(components, dict)
    world, detector = components["world"], components["detector"]
    assert isinstance(world, dict)
    assert isinstance(detector, dict)
    assert world["phases"]["render"] > 0  # type: ignore[index,operator]  # the camera
    assert "infer" in detector["phases"]  # type: ignore[operator]
    assert "step" not in detector["phases"]  # type: ignore[operator]
    assert detector["steps"] == 5  # 10 Hz for 0.5 s


def test_the_cli_prints_the_table_and_writes_run_json(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app,
        ["run", str(_chain(fixture_fmu, write_system)), "--out", str(out), "--profile",
         "--isolate", "none"],
        env={"COLUMNS": "200"},  # the table's header on one line, whatever ran before
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "where the loop's" in result.output
    header = next(line for line in result.output.splitlines() if line.startswith("component"))
    assert header.split() == [
        "component", "share", "steps", "mean", "max", "transfer", "render", "step", "record",
        "setup",
    ]  # fmt: skip
    info = json.loads((out / "run.json").read_text())
    assert set(info["statistics"]["components"]) >= {"slow"}
    assert info["pacing"] is None
