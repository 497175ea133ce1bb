"""``fmionnx run`` as a user meets it: exit codes, files written, Ctrl-C, the last line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.results.csvfile import read_csv
from tests.conftest import finish

CHAIN = """
fmionnx: 1
name: chain
run: {{stop: {stop}, step: 0.001}}
components:
  a: {{kind: fmu, path: {gain}, parameters: {{u: 1.0}}}}
  b: {{kind: fmu, path: {gain}}}
connections:
  - a.y -> b.u
"""


def _cli(*args: str) -> subprocess.Popen[str]:
    code = "import sys; from fmionnx.cli import main; sys.argv[0] = 'fmionnx'; main()"
    return subprocess.Popen(
        [sys.executable, "-c", code, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, COLUMNS="200"),
    )


def test_run_writes_results_and_names_the_folder_last(fixture_fmu, write_system, tmp_path) -> None:
    system = write_system(CHAIN.format(stop=0.5, gain=fixture_fmu("Gain")))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(system), "--out", str(out), "--param", "a.k=4"], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    assert result.output.strip().splitlines()[-1] == f"Results: {out}"
    table = read_csv(out / "results.csv")
    # no `record:`: every output of every component, as other tools record (issue #33)
    assert list(table) == [
        "time",
        *(f"{c}.{p}" for c in "ab" for p in ("y", "w[0]", "w[1]", "w[2]")),
    ]
    assert table["a.y"][-1] == 4.0
    info = json.loads((out / "run.json").read_text())
    assert info["settings_origin"]["record"] == "built-in default"
    assert {"name": "a.k", "value": 4.0, "source": "command line"} in info["parameters"]
    assert info["status"] == "completed"
    assert info["steps"] == 500
    assert set(info["versions"]) >= {"fmionnx", "fmpy", "onnxruntime", "mujoco"}


def test_unknown_parameter_is_a_usage_error(fixture_fmu, write_system) -> None:
    system = write_system(CHAIN.format(stop=0.5, gain=fixture_fmu("Gain")))
    result = CliRunner().invoke(app, ["run", str(system), "--param", "a.kk=4"])
    assert result.exit_code == 2
    assert "did you mean `k`" in result.output


def test_fault_exits_1_and_keeps_results_so_far(fixture_fmu, write_system, tmp_path) -> None:
    system = write_system(
        f"""
fmionnx: 1
name: faulty
run: {{stop: 1.0, step: 0.01}}
components:
  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: 0, failAt: 0.3}}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}}}
connections:
  - bad.y -> gain.u
"""
    )
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(system), "--out", str(out), "-q"])
    assert result.exit_code == 1
    assert "component `bad` at t=0.3 s: fmi2DoStep returned Error" in result.output
    assert read_csv(out / "results.csv")["time"][-1] == 0.3
    assert json.loads((out / "run.json").read_text())["error"]["component"] == "bad"


def test_ctrl_c_stops_cleanly_writes_results_and_exits_130(
    fixture_fmu, write_system, tmp_path
) -> None:
    system = write_system(CHAIN.format(stop=100000, gain=fixture_fmu("Gain")))
    out = tmp_path / "out"
    process = _cli("run", str(system), "--out", str(out), "--checkpoint-every", "0")
    assert process.stderr is not None
    line = process.stderr.readline()
    while line and not line.startswith("running chain"):
        line = process.stderr.readline()
    assert line.startswith("running chain")
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # a checkpoint after some steps: the loop is running
        time.sleep(0.1)
        if (out / "run.json").exists() and json.loads((out / "run.json").read_text())["steps"]:
            break
    process.send_signal(signal.SIGINT)
    stdout, stderr = finish(process, 60)
    assert process.returncode == 130, stderr
    assert stdout.strip().splitlines()[-1] == f"Results: {out}"
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted"
    table = read_csv(out / "results.csv")
    assert table["time"].size == info["steps"] + 1 > 1
    assert np.all(table["a.y"][1:] == 2.0)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--stop-time", "-1"], "--stop-time -1.0 must be greater than the start time 0.0"),
        (["--stop-time", "nan"], "--stop-time nan must be a finite number of seconds"),
        (["--stop-time", "inf"], "--stop-time inf must be a finite number of seconds"),
        (["--stop-time", "0.0005"], "is not a whole number of base steps (0.001 s)"),
        (["--param", "k=2"], "--param `k`: expected `component.name=value` (components: a, b)"),
        (["--param", "c.k=2"], "--param `c.k`: no component `c`"),
        (["--param", "a.kk=2"], "did you mean `k`"),
        (["--param", "a.k"], "--param `a.k` must look like `name=value`"),
    ],
)
def test_bad_overrides_are_usage_errors_before_the_run(
    fixture_fmu, write_system, tmp_path, args: list[str], message: str
) -> None:
    system = write_system(CHAIN.format(stop=0.5, gain=fixture_fmu("Gain")))
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(system), "--out", str(out), *args], env={"COLUMNS": "1000"}
    )
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert not (out / "results.csv").exists()
