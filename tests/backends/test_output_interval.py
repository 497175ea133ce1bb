"""Output interval (issue 13): every k-th communication point is written, the last one always.

``run.output_interval`` in the system file, ``--output-interval`` on ``fmionnx run``, carried
by the compiled system (and its file); and ``--step``/``--start-time`` for every system.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.compile.ir import Origin
from fmionnx.compile.systemfile import from_json, to_json
from fmionnx.runtime.result import RunStatus, output_rows


def _system(fixture_fmu, write_system, *, mode: int = 10, interval: str = "") -> Path:
    run = f"{{stop: 1.0, step: 0.01{', output_interval: ' + interval if interval else ''}}}"
    return write_system(
        f"""
fmionnx: 1
name: sampled
run: {run}
components:
  src: {{kind: signal, outputs: {{u: {{ramp: {{slope: 2}}}}}}}}
  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {mode}, failAt: 0.5}}}}
connections:
  - src.u -> bad.u
record: [bad.u, bad.y]
"""
    )


def test_output_rows_keep_every_kth_point_and_always_the_last() -> None:
    assert output_rows(10, 5).tolist() == [0, 5, 10]
    assert output_rows(12, 5).tolist() == [0, 5, 10, 12]
    assert output_rows(0, 5).tolist() == [0]


def test_interval_keeps_every_kth_row_of_the_full_run(fixture_fmu, write_system) -> None:
    full = fmionnx.load(_system(fixture_fmu, write_system, mode=0)).run(
        isolate="none", stop_time=0.4
    )
    sampled = fmionnx.load(_system(fixture_fmu, write_system, mode=0, interval="0.05")).run(
        isolate="none", stop_time=0.4
    )
    assert sampled.status is full.status is RunStatus.COMPLETED
    assert sampled.steps_done == full.steps_done == 40
    np.testing.assert_array_equal(sampled.time, full.time[::5])
    for name, values in full.signals.items():
        np.testing.assert_array_equal(sampled[name], values[::5])


@pytest.mark.parametrize(
    ("mode", "status", "last"), [(0, RunStatus.FAULT, 0.5), (10, RunStatus.COMPLETED, 0.51)]
)
def test_an_early_end_still_writes_its_last_point(
    fixture_fmu, write_system, mode: int, status: RunStatus, last: float
) -> None:
    full = fmionnx.load(_system(fixture_fmu, write_system, mode=mode)).run(isolate="none")
    sampled = fmionnx.load(_system(fixture_fmu, write_system, mode=mode, interval="0.2")).run(
        isolate="none"
    )
    assert sampled.status is full.status is status
    assert sampled.time.tolist() == pytest.approx([0.0, 0.2, 0.4, last])
    np.testing.assert_array_equal(sampled["bad.y"][-1], full["bad.y"][-1])


def test_the_interval_travels_in_the_compiled_system(fixture_fmu, write_system) -> None:
    compiled = fmionnx.load(_system(fixture_fmu, write_system, interval="0.05")).compiled
    assert compiled.run.output_interval == 0.05
    assert compiled.run.output_every == 5
    assert ("output_interval", Origin.SYSTEM_FILE) in compiled.run.origins
    again = from_json(to_json(compiled))
    assert again.run == compiled.run


def test_cli_output_interval_step_and_start_time_apply_to_a_system(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    path = _system(fixture_fmu, write_system, mode=0)
    args = ["run", str(path), "--out", str(out), "--stop-time", "0.4", "--isolate", "none"]
    flags = ["--step", "0.02", "--start-time", "0.1", "--output-interval", "0.1"]
    result = CliRunner().invoke(app, [*args, *flags])
    assert result.exit_code == 0, result.output
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert (info["start_time"], info["step"], info["output_interval"]) == (0.1, 0.02, 0.1)
    assert info["steps"] == 15
    for key in ("start", "step", "output_interval"):
        assert info["settings_origin"][key] == "command line"
    times = [row.split(",")[0] for row in (out / "results.csv").read_text().splitlines()[1:]]
    assert times == ["0.1", "0.2", "0.30000000000000004", "0.4"]


def test_cli_refuses_an_interval_that_is_not_a_multiple_of_the_step(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    path = _system(fixture_fmu, write_system, mode=0)
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "--output-interval", "0.025"])
    assert result.exit_code == 2
    text = " ".join(result.output.split())
    assert "--output-interval 0.025 is not a whole multiple of the base step 0.01 (E047)" in text
    assert "Traceback" not in result.output
