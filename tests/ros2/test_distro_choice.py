"""Which ROS 2 distribution a run, a node or a ``fmionnx ros2`` command uses.

``--ros-distro`` given on the command line, else the system file's ``ros2: distro:``, else the
default (Jazzy). Observable in a run's ``run.json`` (``execution.ros_distro``), in each node's
log (its ready line names the distribution it speaks) and in a generated launch file.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.backends.ros2.loading import plan_for, resolve_distro, system_distro
from fmionnx.cli.app import app
from fmionnx.compile.ros2.messages import DEFAULT_DISTRO, RosDistro
from fmionnx.spec.model import Ros2Spec
from tests.conftest import build_fixture_fmu
from tests.ros2.conftest import make_system
from tests.ros2.test_run import fmionnx, processes_with


def humble_system(folder: Path, ros2: str = "ros2: {distro: humble}") -> Path:
    """One Gain FMU fed by a ramp, its ``ros2:`` section naming Humble."""
    path = folder / "humble.yaml"
    path.write_text(
        f"""
fmionnx: 1
name: humble
run: {{stop: 0.05, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{u: {{ramp: {{slope: 1}}}}}}}}
  gain: {{kind: fmu, path: {build_fixture_fmu("Gain")}}}
connections:
  - src.u -> gain.u
{ros2}
""",
        encoding="utf-8",
    )
    return path


def test_the_system_distribution_applies_unless_one_is_asked_for() -> None:
    plain, humble = make_system(), make_system(Ros2Spec(distro="humble"))
    assert system_distro(plain) is DEFAULT_DISTRO is RosDistro.JAZZY
    assert system_distro(humble) is RosDistro.HUMBLE
    assert resolve_distro(humble, None) is RosDistro.HUMBLE
    assert resolve_distro(humble, RosDistro.IRON) is RosDistro.IRON
    assert plan_for(humble).distro is RosDistro.HUMBLE
    assert plan_for(humble, RosDistro.KILTED).distro is RosDistro.KILTED


@pytest.mark.parametrize(
    ("ros2", "option", "expected"),
    [
        ("ros2: {distro: humble}", [], "humble"),
        ("ros2: {distro: humble}", ["--ros-distro", "kilted"], "kilted"),
        ("", [], "jazzy"),
    ],
)
def test_launch_file_names_the_chosen_distribution(
    tmp_path: Path, ros2: str, option: list[str], expected: str
) -> None:
    system = humble_system(tmp_path, ros2)
    out = tmp_path / "robot.launch.py"
    done = CliRunner().invoke(app, ["ros2", "launch-file", str(system), "-o", str(out), *option])
    assert done.exit_code == 0, done.output
    assert f"DISTRO = {expected!r}" in out.read_text(encoding="utf-8")


def _ros2_run(system: Path, out: Path, *option: str) -> dict[str, object]:
    done = subprocess.run(
        fmionnx("run", system, "-q", "--backend", "ros2", "--out", out, *option),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    execution = json.loads((out / "run.json").read_text(encoding="utf-8"))["execution"]
    assert isinstance(execution, dict)
    return execution


@pytest.mark.ros2
def test_a_run_uses_the_system_files_distribution_and_the_option_overrides_it(
    tmp_path: Path, loopback_env
) -> None:
    system = humble_system(tmp_path)
    assert _ros2_run(system, tmp_path / "file")["ros_distro"] == "humble"
    assert "ROS 2 humble" in (tmp_path / "file" / "logs" / "gain.log").read_text()
    assert _ros2_run(system, tmp_path / "cli", "--ros-distro", "iron")["ros_distro"] == "iron"
    assert "ROS 2 iron" in (tmp_path / "cli" / "logs" / "gain.log").read_text()
    assert processes_with(str(tmp_path)) == []


@pytest.mark.ros2
def test_a_node_uses_the_system_files_distribution(tmp_path: Path, loopback_env) -> None:
    log = tmp_path / "node.log"
    with log.open("w") as sink:
        node = subprocess.Popen(
            fmionnx("node", humble_system(tmp_path), "gain", "--sync", "free"),
            stdout=sink,
            stderr=subprocess.STDOUT,
        )
    try:
        deadline = time.monotonic() + 60
        while "ready" not in log.read_text() and node.poll() is None:
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.1)
    finally:
        node.send_signal(signal.SIGTERM)
        node.wait(timeout=30)
    assert "ready, sync free, ROS 2 humble" in log.read_text()
