"""Real time in-process (``--rtf``): a paced run takes simulated time / rtf of wall time, and
one that cannot keep up says so (summary, warning, run.json), never silently.

Behaviour, not speed: the bounds are generous (a loaded machine sleeps late, never early).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.runtime.result import RunStatus


def _system(fixture_fmu, write_system, *, stop: float, step: float) -> Path:
    return write_system(
        f"""
fmionnx: 1
name: paced
run: {{stop: {stop}, step: {step}}}
components:
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}}}
  integrator: {{kind: fmu, path: {fixture_fmu("Integrator")}}}
connections:
  - gain.y -> integrator.u
"""
    )


@pytest.mark.slow
def test_rtf_2_takes_about_half_the_simulated_time(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_system(fixture_fmu, write_system, stop=2.0, step=0.01))
    began = time.perf_counter()
    result = system.run(isolate="none", rtf=2.0)
    took = time.perf_counter() - began
    assert result.status is RunStatus.COMPLETED
    assert 0.9 <= result.wall_time <= 2.0  # 1 s expected; a sleep can wake late, never early
    assert took >= 0.9
    pacing = result.pacing
    assert pacing is not None
    assert pacing["rtf"] == 2.0
    assert pacing["steps"] == 200
    assert pacing["waited"] > 0.5  # type: ignore[operator]  # the FMUs take microseconds
    assert result.statistics is None  # timed for the pacer, not reported unless asked


def test_an_unpaced_run_is_not_paced(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_system(fixture_fmu, write_system, stop=2.0, step=0.01))
    result = system.run(isolate="none")
    assert result.pacing is None
    assert result.wall_time < 0.9  # 200 steps of two tiny FMUs


def test_a_run_that_cannot_keep_up_says_so(fixture_fmu, write_system, tmp_path: Path) -> None:
    """1 ms of simulated time in 1 µs of wall time per step is more than any loop can do."""
    path = _system(fixture_fmu, write_system, stop=0.5, step=0.001)
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(path), "--out", str(out), "--isolate", "none", "--rtf", "1000"]
    )
    assert result.exit_code == 0, result.output  # behind is not a fault
    output = " ".join(result.output.split())
    assert "warning: --rtf 1000: the run could not keep up: it ended" in output
    assert "could not keep up" in output  # the summary's pacing row too
    info = json.loads((out / "run.json").read_text())
    pacing = info["pacing"]
    assert pacing["kept_up"] is False
    assert pacing["late_steps"] > 0
    assert pacing["max_lateness"] > 0
    assert pacing["behind_at_end"] > 0
    assert any("could not keep up" in w for w in info["warnings"])
    worst = pacing["worst_overrun"]
    assert worst["took"] > worst["budget"]
    assert set(worst["by"]) <= {"gain", "integrator", "gain+integrator"}


def test_rtf_must_be_a_pace(fixture_fmu, write_system) -> None:
    path = _system(fixture_fmu, write_system, stop=0.1, step=0.01)
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "--rtf", "-1"])
    assert result.exit_code == 2
    assert "--rtf must be a finite number >= 0" in result.output


def test_a_late_steps_breakdown_counts_the_steps_run_on_lanes(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    """A bug hunt: with `--schedule parallel` the pacer took its breakdown before the lanes'
    steps had finished, so an isolated FMU's round trip (tens of µs at least) was attributed
    to nobody (2 µs: its hand-over). A paced base step now ends with its lanes' work."""
    path = write_system(
        f"""
fmionnx: 1
name: lanes
run: {{stop: 0.2, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{u: {{sine: {{amplitude: 1, frequency: 1}}}}}}}}
  g: {{kind: fmu, path: {fixture_fmu("Gain")}}}
connections:
  - src.u -> g.u
"""
    )
    out = tmp_path / "out"
    args = ["run", str(path), "--out", str(out), "--rtf", "1000", "--schedule", "parallel"]
    result = CliRunner().invoke(app, [*args, "--isolate", "fmus"])
    assert result.exit_code == 0, result.output
    worst = json.loads((out / "run.json").read_text())["pacing"]["worst_overrun"]
    assert worst["by"]["g"] >= 2e-5, worst
