"""Who sends ``/clock`` when no supervisor runs: a launch file of a system without a simulator.

Every free-running node follows ``/clock``; the simulator's node sends it, or the supervisor of
``run --backend ros2 --sync free``. A launch file of a system without a simulator started
nodes that waited for ever, in silence. Now its first node gets ``--clock-source``, and a node
that hears no ``/clock`` says so in its log. Real node processes on loopback DDS.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import queue
import subprocess
import sys
import threading
import time
import types
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import REPO, end_process
from tests.ros2.test_run import fmionnx, processes_with

pytestmark = pytest.mark.ros2


def launched(system: Path, target: Path) -> list[dict[str, Any]]:
    """The processes the launch file written for ``system`` starts (``launch`` is stubbed: ROS
    2 is not installed here)."""
    done = subprocess.run(
        fmionnx("ros2", "launch-file", system, "-o", target),
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    launch = types.ModuleType("launch")
    actions = types.ModuleType("launch.actions")
    launch.LaunchDescription = list  # type: ignore[attr-defined]
    actions.ExecuteProcess = lambda **kwargs: kwargs  # type: ignore[attr-defined]
    launch.actions = actions  # type: ignore[attr-defined]
    sys.modules.update({"launch": launch, "launch.actions": actions})
    try:
        spec = importlib.util.spec_from_file_location("hy_launch", target)
        assert spec is not None
        assert spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        processes: list[dict[str, Any]] = module.generate_launch_description()
    finally:
        del sys.modules["launch"], sys.modules["launch.actions"]
    return processes


def test_a_launch_file_without_a_simulator_makes_its_first_node_the_clock_and_runs_to_the_end(
    system: Path, tmp_path: Path, loopback_env
) -> None:
    processes = launched(system, tmp_path / "hy.launch.py")
    commands = {p["name"]: p["cmd"] for p in processes}
    assert commands["my_src"][-1] == "--clock-source"
    assert "--clock-source" not in commands["gain"]  # with a simulator, none has it: the
    # simulator's node is the clock (test_graph_launch checks the reference system's commands)
    records = tmp_path / "records"
    started = []
    for cmd in commands.values():  # as `ros2 launch` would start them, plus a record folder
        command = [sys.executable, "-m", "fmionnx", *cmd[1:], "--record-dir", str(records)]
        started.append(
            subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        )
    try:
        for process in started:
            _, stderr = process.communicate(timeout=60)  # before: waited for /clock for ever
            assert process.returncode == 0, stderr
    finally:
        for process in started:
            end_process(process)
    status = json.loads((records / "gain.json").read_text(encoding="utf-8"))
    assert (status["status"], status["steps"]) == ("completed", 10)
    assert processes_with(str(tmp_path)) == []


def test_a_node_hearing_no_clock_says_so_in_its_log(system: Path, loopback_env) -> None:
    process = subprocess.Popen(
        fmionnx("node", system, "gain", "--sync", "free"),
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    lines: queue.Queue[str] = queue.Queue()
    assert process.stderr is not None
    reader = threading.Thread(target=lambda: [lines.put(line) for line in process.stderr or ()])
    reader.start()  # a thread: before, the node printed nothing more and a read never returned
    seen: list[str] = []
    try:
        deadline = time.monotonic() + 30
        while not any("no /clock sample" in line for line in seen):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            with contextlib.suppress(queue.Empty):
                seen.append(lines.get(timeout=remaining))
    finally:
        process.kill()
        process.wait(timeout=30)
        reader.join(timeout=30)
        process.stderr.close()
    text = "".join(seen)
    assert "WARNING no /clock sample in 5 s, still waiting" in text, text
    assert "--clock-source" in text


@pytest.mark.parametrize(
    ("path", "args", "message"),
    [
        (None, ["--sync", "lockstep"], "--clock-source applies to --sync free"),
        (None, ["--supervised"], "--clock-source applies to --sync free without --supervised"),
        (
            REPO / "systems" / "sign_follower.yaml",
            [],
            "--clock-source: the simulator `world` publishes /clock in this system",
        ),
    ],
)
def test_clock_source_is_refused_where_another_clock_runs(
    system: Path, path: Path | None, args: list[str], message: str
) -> None:
    target = path or system
    component = "tracker" if path else "gain"
    done = subprocess.run(
        fmionnx("node", target, component, "--clock-source", *args),
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert message in " ".join(done.stderr.split())
