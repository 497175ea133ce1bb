"""fmionnx nodes against a real ROS 2 client library: rclpy (ROS 2 Jazzy wheels, Fast DDS).

rclpy runs only in child processes (``rclpy_peer.py``, or ``fmionnx node --middleware rclpy``),
never in the pytest process. Every test uses a random domain with the LOCALHOST discovery
range, as a ROS 2 user on this host would (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
Skipped, with the reason, where rclpy cannot run (not installed, foreign RMW_IMPLEMENTATION).
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from fmionnx.api import load
from fmionnx.backends.ros2.loading import plan_for
from fmionnx.backends.ros2.rclpy_env import rclpy_problem
from fmionnx.backends.ros2.supervisor import SUPERVISOR_NODE
from fmionnx.compile.ros2.messages import RosDistro
from tests.conftest import REPO, built_model, end_process
from tests.ros2.test_run import fmionnx, processes_with

pytestmark = pytest.mark.ros2

PEER = Path(__file__).with_name("rclpy_peer.py")
SYSTEM = REPO / "systems" / "sign_follower.yaml"
#: Simulated seconds of the runs here: long enough for commands and detections, short to run.
STOP = "4"


@pytest.fixture(scope="module")
def rclpy_env() -> Iterator[None]:
    """Skip without a usable rclpy; else a random domain, LOCALHOST range, for every child."""
    problem = rclpy_problem()
    if problem is not None:
        pytest.skip(f"rclpy cannot run here: {problem}")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randint(200, 209)))
        patch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        for name in ("ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS", "CYCLONEDDS_URI"):
            patch.delenv(name, raising=False)
        yield


def _peer(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, str(PEER), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(child: subprocess.Popen[str], timeout: float) -> tuple[str, str]:
    """Output of a child that ends by itself, or what it wrote until killed after ``timeout``."""
    try:
        return child.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        child.kill()
        return child.communicate()


def _run(system: Path, out: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        fmionnx("run", system, "--no-checks", "-q", "--backend", "ros2", "--ros-distro", "jazzy",
                "--stop-time", STOP, "--out", out, *args),
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )  # fmt: skip


def _wait_ready(run: subprocess.Popen[str], logs: Path, components: list[str]) -> None:
    """Until every node logged that it is ready (the run fails the test if it ends first)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and run.poll() is None:
        texts = [logs / f"{c}.log" for c in components]
        if all(t.exists() and " ready, sync " in t.read_text(encoding="utf-8") for t in texts):
            return
        time.sleep(0.1)
    pytest.fail("the fmionnx nodes did not all become ready")


@pytest.fixture(scope="module")
def observed_run(rclpy_env: None, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A free run on Cyclone DDS; once its nodes are up, two rclpy programs join it, as a user
    typing ``ros2 node list`` or ``ros2 topic echo /cmd_vel`` would: a graph probe, a listener.
    """
    built_model("ReadOdometry.fmu")
    plan = plan_for(load(SYSTEM).compiled, RosDistro.JAZZY)
    names = [node.fqn for node in plan.nodes]
    tmp = tmp_path_factory.mktemp("observed")
    run = subprocess.Popen(
        fmionnx("run", SYSTEM, "--no-checks", "-q", "--backend", "ros2", "--ros-distro", "jazzy",
                "--stop-time", "8", "--sync", "free", "--out", tmp / "out"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    peers: list[subprocess.Popen[str]] = []
    try:
        _wait_ready(run, tmp / "out" / "logs", [node.component for node in plan.nodes])
        peers.append(_peer("graph", "30", *names, f"/{SUPERVISOR_NODE}"))
        peers.append(_peer("twist-sub", "100000", "30"))
        _, run_err = _finish(run, 180)
        report, graph_err = _finish(peers[0], 30)
        commands, _ = _finish(peers[1], 30)
    finally:
        for child in [run, *peers]:  # only when something above failed
            end_process(child)
    assert run.returncode == 0, run_err
    return {
        "plan": plan,
        "graph": json.loads(report or "{}"),
        "graph_stderr": graph_err,
        "commands": [json.loads(line) for line in commands.splitlines()[1:]],
        "tmp": tmp,
    }


def test_rclpy_graph_lists_every_reference_node_by_its_paper_name_with_its_topics(
    observed_run: dict[str, Any],
) -> None:
    plan, graph = observed_run["plan"], observed_run["graph"]
    expected = {node.fqn for node in plan.nodes}
    assert expected == {
        "/simulator", "/fmu_odometry_node", "/onnx_sign_detector_node", "/fmu_sign_tracking_node"
    }  # fmt: skip
    assert expected | {f"/{SUPERVISOR_NODE}"} <= set(graph["nodes"]), observed_run["graph_stderr"]
    for node in plan.nodes:
        published = dict(graph["publishers"][node.fqn])
        subscribed = dict(graph["subscribers"][node.fqn])
        for topic in node.publishes:
            assert published[topic] == [plan.topic(topic).msgtype], (node.fqn, topic)
        for topic in node.subscribes:
            assert subscribed[topic] == [plan.topic(topic).msgtype], (node.fqn, topic)
        assert "/clock" in subscribed  # every node follows the simulated clock
    tracker = graph["publishers"]["/fmu_sign_tracking_node"]
    assert ["/cmd_vel", ["geometry_msgs/msg/Twist"]] in tracker


def test_rclpy_subscriber_on_cmd_vel_receives_the_trackers_twist_commands(
    observed_run: dict[str, Any],
) -> None:
    commands = observed_run["commands"]
    assert len(commands) >= 50  # 100 Hz for the seconds after the listener joined
    assert {c["x"] for c in commands} <= {0.0, 0.4, 0.5}  # stopped, approach, cruise
    assert max(c["x"] for c in commands) > 0
    assert processes_with(str(observed_run["tmp"])) == []


@pytest.mark.slow  # the DDS wire's test of an external world's images stays in `make test`
def test_rclpy_image_publisher_on_camera_image_raw_drives_the_detector_of_an_external_world(
    rclpy_env: None, tmp_path: Path
) -> None:
    built_model("sign_detector.onnx")
    text = SYSTEM.read_text(encoding="utf-8").replace("../", f"{REPO.as_posix()}/")
    text = text.replace("    kind: mujoco\n", "    kind: mujoco\n    external: true\n", 1)
    system = tmp_path / "external.yaml"
    system.write_text(text, encoding="utf-8")
    camera = _peer("image-pub", "60")
    try:
        done = _run(system, tmp_path / "out", "--sync", "free")
    finally:
        seen, camera_err = _finish(camera, 60)
    assert done.returncode == 0, done.stderr
    red = json.loads(seen or "{}").get("red")
    assert red is not None, f"no detection of the rclpy image reached rclpy: {camera_err[-2000:]}"
    assert red == pytest.approx(282.8427, rel=1e-4)
    assert processes_with(str(tmp_path)) == []


def test_lockstep_run_with_middleware_rclpy_equals_the_inprocess_results(
    rclpy_env: None, tmp_path: Path
) -> None:
    built_model("ReadOdometry.fmu")
    inprocess = tmp_path / "inprocess"
    subprocess.run(
        fmionnx("run", SYSTEM, "--no-checks", "-q", "--stop-time", STOP, "--out", inprocess),
        check=True,
        timeout=120,
    )
    out = tmp_path / "rclpy"
    done = _run(SYSTEM, out, "--sync", "lockstep", "--middleware", "rclpy")
    assert done.returncode == 0, done.stderr
    assert (out / "results.csv").read_bytes() == (inprocess / "results.csv").read_bytes()
    log = (out / "logs" / "tracker.log").read_text(encoding="utf-8")
    assert "node /fmu_sign_tracking_node (tracker) ready" in log
    assert processes_with(str(tmp_path)) == []


@pytest.mark.parametrize("command", ["run", "node"])
def test_middleware_rclpy_with_an_rmw_implementation_that_is_not_installed_is_a_clear_error(
    rclpy_env: None, monkeypatch: pytest.MonkeyPatch, command: str
) -> None:
    # rcl itself would end the process with status 102 while loading; fmionnx says why first.
    monkeypatch.setenv("RMW_IMPLEMENTATION", "rmw_nowhere_cpp")
    argv = ["run", SYSTEM, "--backend", "ros2"] if command == "run" else ["node", SYSTEM, "tracker"]
    done = subprocess.run(
        fmionnx(*argv, "--ros-distro", "jazzy", "--middleware", "rclpy"),
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == (2 if command == "run" else 1), done.stderr  # usage / problem
    text = " ".join(done.stderr.split())
    assert (
        "RMW_IMPLEMENTATION=rmw_nowhere_cpp names a ROS 2 middleware that is not installed" in text
    )
    assert "Traceback" not in done.stderr


def test_middleware_rclpy_asks_for_the_distribution_of_the_rclpy_found(rclpy_env: None) -> None:
    done = subprocess.run(
        fmionnx("run", SYSTEM, "--backend", "ros2", "--ros-distro", "humble", "--middleware",
                "rclpy"),
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 2
    assert "the rclpy here is ROS 2 jazzy: add `--ros-distro jazzy`" in " ".join(
        done.stderr.split()
    )
