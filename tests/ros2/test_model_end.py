"""A model ending the simulation ends a ROS 2 run normally, as it ends an in-process run.

The ``Faulty`` fixture in mode 10 asks to terminate from its step at ``failAt`` (fmi2DoStep:
Discard, fmi2Terminated). Its node records that step, exits with status 3 (``ENDED_BY_MODEL``);
the supervisor lets the nodes before it in the order finish that step, stops the others, and
reports ``ended_by`` like in-process: ``results.csv`` of a lockstep run is the in-process one
byte for byte, including a component that is independent of the ending one on each side of it
in the order (``early`` steps at 0.3, ``late`` does not).
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from tests.conftest import build_fixture_fmu
from tests.ros2.test_run import fmionnx, processes_with

pytestmark = pytest.mark.ros2

ENDED = {"component": "bad", "time": 0.31, "reason": "the FMU requested termination"}


def ending_system(folder: Path) -> Path:
    """src -> bad -> tail, and two gains fed by src only: one before bad in the order, one
    after it (the order keeps the file's order between independent components)."""
    gain, faulty = build_fixture_fmu("Gain"), build_fixture_fmu("Faulty")
    path = folder / "ending.yaml"
    path.write_text(
        f"""
fmionnx: 1
name: ending
run: {{stop: 1.0, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{u: {{ramp: {{slope: 2}}}}}}}}
  early: {{kind: fmu, path: {gain}}}
  bad: {{kind: fmu, path: {faulty}, parameters: {{mode: 10, failAt: 0.3}}}}
  tail: {{kind: fmu, path: {gain}}}
  late: {{kind: fmu, path: {gain}}}
connections:
  - src.u -> early.u
  - src.u -> bad.u
  - bad.y -> tail.u
  - src.u -> late.u
record: [bad.u, bad.y, early.y, tail.y, late.y]
""",
        encoding="utf-8",
    )
    return path


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        fmionnx("run", *args), capture_output=True, text=True, timeout=120, check=False
    )


def test_a_model_ending_a_lockstep_run_ends_it_like_in_process(
    tmp_path: Path, loopback_env
) -> None:
    system = ending_system(tmp_path)
    inprocess, ros2 = tmp_path / "inprocess", tmp_path / "ros2"
    assert _run(system, "-q", "--out", inprocess).returncode == 0
    done = _run(system, "--backend", "ros2", "--sync", "lockstep", "--out", ros2)
    assert done.returncode == 0, done.stderr
    text = " ".join(done.stderr.split())
    assert "ended at t=0.31 s by component `bad`: the FMU requested termination" in text
    assert "fault" not in text
    expected = (inprocess / "results.csv").read_bytes()
    assert expected.count(b"\n") == 33  # header + t = 0 .. 0.31
    assert (ros2 / "results.csv").read_bytes() == expected
    rows = [line.split(",") for line in expected.decode().splitlines()]
    column = rows[0].index
    # early stepped at 0.3 (before bad in the order), late did not: the run ended first
    assert rows[-1][column("early.y")] != rows[-2][column("early.y")]
    assert rows[-1][column("late.y")] == rows[-2][column("late.y")]
    info = json.loads((ros2 / "run.json").read_text(encoding="utf-8"))
    assert (info["status"], info["error"], info["ended_by"]) == ("completed", None, ENDED)
    assert json.loads((inprocess / "run.json").read_text(encoding="utf-8"))["ended_by"] == ENDED
    status = json.loads((ros2 / "nodes" / "bad.json").read_text(encoding="utf-8"))
    assert (status["status"], status["steps"], status["ended_by"]["step"]) == ("ended", 31, 30)
    assert "the model ended the simulation at t=0.31 s" in (ros2 / "logs" / "bad.log").read_text()
    assert processes_with(str(tmp_path)) == []


def test_a_model_ending_a_free_run_ends_it_normally(tmp_path: Path, loopback_env) -> None:
    out = tmp_path / "free"
    done = _run(ending_system(tmp_path), "-q", "--backend", "ros2", "--sync", "free",
                "--rtf", "0", "--out", out)  # fmt: skip
    assert done.returncode == 0, done.stderr
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert (info["status"], info["ended_by"]) == ("completed", ENDED)
    last = (out / "results.csv").read_text(encoding="utf-8").splitlines()[-1]
    assert last.startswith("0.31,")
    assert processes_with(str(tmp_path)) == []
