"""``--profile`` and ``--on-nonfinite`` on the ROS 2 backend: the same per node.

Real node processes on loopback DDS (a random domain). Each profiled node times its
component's phases and its exchanges (waiting for inputs, publishing); run.json's
``statistics`` gathers them. A node's transfers guard against non-finite values as the
in-process master's do: by default a fault naming component, port and time; with ``warn``
the run completes and names the value among its warnings.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import build_fixture_fmu

pytestmark = pytest.mark.ros2


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fmionnx", "run", *map(str, args)],
        capture_output=True, text=True, timeout=180, check=False,
    )  # fmt: skip


def _system(folder: Path, mode: int) -> Path:
    path = folder / "system.yaml"
    path.write_text(
        f"""
fmionnx: 1
name: nodes
run: {{stop: 0.5, step: 0.01}}
components:
  bad: {{kind: fmu, path: {build_fixture_fmu("Faulty")}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  gain: {{kind: fmu, path: {build_fixture_fmu("Gain")}}}
connections:
  - bad.y -> gain.u
""",
        encoding="utf-8",
    )
    return path


def test_each_node_reports_its_component_statistics(tmp_path: Path, loopback_env) -> None:
    out = tmp_path / "out"
    done = _run(_system(tmp_path, 2), "-q", "--backend", "ros2", "--out", out,
                "--profile", "--no-checks", "--stop-time", "0.2")  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    info = json.loads((out / "run.json").read_text())
    stats = info["statistics"]
    assert set(stats["components"]) == {"bad", "gain"}
    for entry in stats["components"].values():
        assert entry["steps"] == 20
        assert entry["phases"]["instantiate"] > 0
        assert entry["phases"]["step"] > 0
        assert 0 < entry["share"] <= 1
        assert entry["node_stepping_time"] > 0
    assert set(stats["other"]) == {"bad", "gain"}
    assert all(other["exchange"] >= 0 for other in stats["other"].values())


def test_a_nonfinite_value_in_a_node_is_a_fault_or_a_warning(tmp_path: Path, loopback_env) -> None:
    system = _system(tmp_path, 14)  # Faulty: y becomes +inf
    done = _run(system, "-q", "--backend", "ros2", "--out", tmp_path / "fault", "--no-checks")
    assert done.returncode == 1
    text = " ".join(done.stderr.split())
    assert "component `bad`, port `y` at t=0.29 s: inf on the connection `bad.y -> gain.u`" in text
    warned = tmp_path / "warn"
    done = _run(system, "-q", "--backend", "ros2", "--out", warned, "--no-checks",
                "--on-nonfinite", "warn")  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    info = json.loads((warned / "run.json").read_text())
    assert info["status"] == "completed"
    assert len(info["warnings"]) == 1
    assert info["warnings"][0].startswith("node gain: component `bad`, port `y` at t=0.29 s: inf")
