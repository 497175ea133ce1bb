"""``fmionnx ros2 graph`` against running nodes and a foreign reader; ``ros2 launch-file``."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import time
import types
from pathlib import Path

import pytest

from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES
from tests.conftest import REPO
from tests.ros2.test_run import fmionnx, loop_system, processes_with

pytestmark = pytest.mark.ros2


def _graph(system: Path, timeout: float) -> tuple[int, dict[str, object]]:
    done = subprocess.run(
        fmionnx(
            "ros2",
            "graph",
            system,
            "--format",
            "json",
            "--timeout",
            timeout,
            "--ros-distro",
            "humble",
        ),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    return done.returncode, json.loads(done.stdout)


def test_graph_flags_every_link_missing_when_no_node_runs(tmp_path: Path, loopback_env) -> None:
    code, report = _graph(loop_system(tmp_path, 1.0), 0.3)
    assert code == 1
    assert report["ok"] == []
    assert {"node": "/gain", "kind": "pub", "topic": "/gain/y"} in report["missing"]


def test_graph_shows_running_nodes_and_flags_a_foreign_reader_as_extra(
    tmp_path: Path, loopback_env
) -> None:
    system = loop_system(tmp_path, 10000.0)
    out = tmp_path / "out"
    run = subprocess.Popen(
        fmionnx(
            "run",
            system,
            "-q",
            "--backend",
            "ros2",
            "--sync",
            "free",
            "--out",
            out,
            "--ros-distro",
            "humble",
        ),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    participant = Participant(from_environment(RosDistro.HUMBLE))
    try:
        foreign = participant.reader("rt/gain/y", "std_msgs/msg/Float64", PROFILES["default"])
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            logs = [out / "logs" / f"{n}.log" for n in ("gain", "integ", "integ2")]
            if all(p.exists() and "ready" in p.read_text() for p in logs):
                break
            time.sleep(0.2)
        code, report = _graph(system, 2.0)
        assert foreign.matched() == 1  # the gain node's writer
    finally:
        participant.close()
        run.terminate()
        run.communicate(timeout=60)
    assert code == 0, report
    assert report["missing"] == []
    assert {"/gain", "/integ", "/integ2", "/fmionnx_supervisor"} <= set(report["nodes"])
    assert {"node": "/integ", "kind": "sub", "topic": "/gain/y"} in report["ok"]
    extra = report["extra"]
    assert len(extra) == 1
    assert extra[0]["kind"] == "sub"
    assert extra[0]["topic"] == "/gain/y"
    assert extra[0]["node"].startswith("(participant ")
    assert report["topics"]["/gain/y"]["types"] == ["std_msgs/msg/Float64"]
    assert processes_with(str(tmp_path)) == []


def test_launch_file_is_python_defining_one_node_process_per_component(tmp_path: Path) -> None:
    target = tmp_path / "launch" / "robot.launch.py"
    done = subprocess.run(
        fmionnx("ros2", "launch-file", REPO / "systems" / "sign_follower.yaml", "-o", target),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    # `launch` (ROS 2) is not installed here: a stub records what the file builds.
    assert importlib.util.find_spec("launch") is None
    launch = types.ModuleType("launch")
    actions = types.ModuleType("launch.actions")
    launch.LaunchDescription = list  # type: ignore[attr-defined]
    actions.ExecuteProcess = lambda **kwargs: kwargs  # type: ignore[attr-defined]
    launch.actions = actions  # type: ignore[attr-defined]
    sys.modules.update({"launch": launch, "launch.actions": actions})
    try:
        spec = importlib.util.spec_from_file_location("robot_launch", target)
        assert spec is not None
        assert spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        processes = module.generate_launch_description()
    finally:
        del sys.modules["launch"], sys.modules["launch.actions"]
    names = [p["name"] for p in processes]
    assert names == ["simulator", "fmu_odometry_node", "onnx_sign_detector_node",
                     "fmu_sign_tracking_node"]  # fmt: skip
    first = processes[0]["cmd"]
    assert first[:2] == ["fmionnx", "node"]
    assert Path(first[2]).resolve() == (REPO / "systems" / "sign_follower.yaml").resolve()
    assert first[3:] == ["world", "--sync", "free", "--ros-distro", "jazzy", "--middleware", "dds"]
    assert processes[0]["additional_env"] == {}
