"""``--middleware zenoh``: real node processes on the rmw_zenoh wire, each test with a router
and a domain of its own.

Checked against two observers fmionnx did not shape: ``zenoh-ros2-sdk`` (an rmw_zenoh client
from PyPI) in a child process, and :mod:`tests.ros2.zenoh.checker`, written directly on
``eclipse-zenoh`` from the wire facts. No process and no router may outlive a run, whether it
completes, is interrupted or loses a node.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fmionnx.backends.ros2.zenoh.config import zenoh_environment
from fmionnx.backends.ros2.zenoh.router import InProcessRouter, free_port, reachable
from fmionnx.backends.ros2.zenoh.transport import ZenohTransport
from fmionnx.compile.ros2.messages import RosDistro, deserialize
from fmionnx.compile.ros2.qos import PROFILES
from fmionnx.results.csvfile import read_csv
from tests.conftest import REPO, built_model, end_process
from tests.ros2.test_run import fmionnx, loop_system, processes_with, wait_for_nodes
from tests.ros2.zenoh import checker

pytestmark = pytest.mark.ros2

SYSTEM = REPO / "systems" / "sign_follower.yaml"
PEER = Path(__file__).with_name("sdk_peer.py")
PAPER_NODES = {"/simulator", "/fmu_odometry_node", "/onnx_sign_detector_node",
               "/fmu_sign_tracking_node"}  # fmt: skip
GOAL_B = np.array([6.0, 3.0])


def _zenoh_run(system: Path, out: Path, *args: str | Path) -> list[str]:
    return fmionnx("run", system, "--backend", "ros2", "--middleware", "zenoh", "--out", out,
                   *args)  # fmt: skip


def _unused_router(monkeypatch: pytest.MonkeyPatch) -> str:
    """Point the Zenoh configuration at a port where no router runs (so `auto` starts one)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", f'connect/endpoints=["{endpoint}"]')
    return endpoint


@pytest.mark.parametrize("distro", ["humble", "kilted"])  # jazzy: the reference test below
def test_lockstep_over_zenoh_equals_inprocess_with_its_own_router_and_records_the_wire(
    tmp_path: Path, zenoh_domain: int, monkeypatch: pytest.MonkeyPatch, distro: str
) -> None:
    _unused_router(monkeypatch)
    system = loop_system(tmp_path, 1.0)
    inprocess, zenoh_out, bag = tmp_path / "inprocess", tmp_path / "zenoh", tmp_path / "wire.mcap"
    subprocess.run(fmionnx("run", system, "-q", "--out", inprocess), check=True, timeout=60)
    done = subprocess.run(
        _zenoh_run(system, zenoh_out, "--record", bag, "--ros-distro", distro), capture_output=True, text=True,
        timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert (zenoh_out / "results.csv").read_bytes() == (inprocess / "results.csv").read_bytes()
    execution = json.loads((zenoh_out / "run.json").read_text())["execution"]
    assert execution["middleware"] == "zenoh"
    assert execution["ros_distro"] == distro
    assert execution["zenoh_router"].startswith("started in-process on tcp/127.0.0.1:")
    assert "zenoh router" in done.stderr  # the summary table
    assert "started in-process on tcp/127.0.0.1:" in done.stderr
    endpoint = execution["zenoh_router"].rsplit(" ", 1)[1]
    assert not reachable(endpoint)  # the router ended with the supervisor

    from mcap.reader import make_reader

    with bag.open("rb") as stream:
        reader = make_reader(stream)
        counts: dict[str, int] = {}
        for _, channel, message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            assert message.data[:4] == b"\x00\x01\x00\x00"  # CDR little endian, as sent
    assert counts["/clock"] >= 101
    assert len(counts) >= 4
    assert processes_with(str(tmp_path)) == []


def test_reference_lockstep_over_zenoh_feeds_an_rmw_zenoh_client_and_follows_the_wire_facts(
    tmp_path: Path, router: InProcessRouter, zenoh_domain: int
) -> None:
    built_model("ReadOdometry.fmu")
    inprocess, zenoh_out = tmp_path / "inprocess", tmp_path / "zenoh"
    subprocess.run(fmionnx("run", SYSTEM, "-q", "--stop-time", "3", "--no-checks", "--out", inprocess),
                   check=True, timeout=120)  # fmt: skip
    listener = subprocess.Popen(
        [sys.executable, str(PEER), "twist-sub", str(router.port), "300"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    watch = checker.Checker(router.endpoint, zenoh_domain)
    try:
        assert listener.stdout is not None
        assert json.loads(listener.stdout.readline()) == {"ready": True}
        done = subprocess.run(
            _zenoh_run(SYSTEM, zenoh_out, "-q", "--stop-time", "3", "--no-checks",
                       "--zenoh-router", router.endpoint),
            capture_output=True, text=True, timeout=240, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        received, _ = listener.communicate(timeout=60)
    finally:
        seen = watch.close()
        end_process(listener)
    assert (zenoh_out / "results.csv").read_bytes() == (inprocess / "results.csv").read_bytes()
    commands = [json.loads(line) for line in received.splitlines()]
    assert len(commands) >= 300
    assert {c["x"] for c in commands} <= {0.0, 0.4, 0.5}
    assert max(c["x"] for c in commands) > 0

    # The liveliness graph: every node of the paper by name, with its endpoints.
    assert checker.nodes(seen.tokens) >= PAPER_NODES
    publishers = checker.endpoints(seen.tokens, "MP")
    subscriptions = checker.endpoints(seen.tokens, "MS")
    assert ("/fmu_sign_tracking_node", "/cmd_vel", "geometry_msgs/msg/Twist") in publishers
    assert ("/simulator", "/camera/image_raw", "sensor_msgs/msg/Image") in publishers
    assert (
        "/onnx_sign_detector_node",
        "/camera/image_raw",
        "sensor_msgs/msg/Image",
    ) in subscriptions
    assert ("/simulator", "/cmd_vel", "geometry_msgs/msg/Twist") in subscriptions
    assert ("/fmu_odometry_node", "/odom", "nav_msgs/msg/Odometry") in subscriptions
    for node in PAPER_NODES:
        assert any(p[0] == node for p in publishers), node
        assert any(s[0] == node for s in subscriptions), node  # /clock at least

    # Attachments: per publisher sequence numbers 1, 2, 3, ... and the GID of its token.
    gids = checker.publisher_gids(seen.tokens)
    assert seen.no_attachment == []
    assert seen.malformed == []
    cmd_vel = [k for k in seen.samples if k.startswith(f"{zenoh_domain}/cmd_vel/")]
    assert cmd_vel == [
        f"{zenoh_domain}/cmd_vel/geometry_msgs::msg::dds_::Twist_/"
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
    ]
    for key, samples in seen.samples.items():
        by_gid: dict[bytes, list[int]] = {}
        for sequence, _, gid in samples:
            by_gid.setdefault(gid, []).append(sequence)
        for gid, sequences in by_gid.items():
            assert gid in gids, f"{key}: GID {gid.hex()} is not the hash of a publisher token"
            topic = "/" + key.split("/", 1)[1].rsplit("/", 2)[0]
            assert gids[gid].split("/")[9].replace("%", "/") == topic
            assert sequences == list(range(1, len(sequences) + 1)), key
    assert processes_with(str(tmp_path)) == []


def test_free_run_over_zenoh_reaches_b_and_the_graph_command_sees_every_link(
    tmp_path: Path, router: InProcessRouter
) -> None:
    built_model("ReadOdometry.fmu")
    out = tmp_path / "free"
    run = subprocess.Popen(
        _zenoh_run(SYSTEM, out, "-q", "--sync", "free", "--rtf", "2", "--zenoh-router",
                   router.endpoint),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        wait_for_nodes(str(tmp_path), 4)
        graph = None
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and run.poll() is None:
            graph = subprocess.run(
                fmionnx("ros2", "graph", SYSTEM, "--middleware", "zenoh", "--zenoh-router",
                        router.endpoint, "--timeout", "1", "--format", "json"),
                capture_output=True, text=True, timeout=60, check=False,
            )  # fmt: skip
            if graph.returncode == 0:
                break
        _, stderr = run.communicate(timeout=240)
    finally:
        end_process(run)
    assert graph is not None
    assert graph.returncode == 0, graph.stdout + graph.stderr
    report = json.loads(graph.stdout)
    assert report["missing"] == []
    assert set(report["nodes"]) >= PAPER_NODES
    assert "/fmionnx_supervisor" in report["nodes"]
    assert report["topics"]["/cmd_vel"]["types"] == ["geometry_msgs/msg/Twist"]
    assert report["topics"]["/cmd_vel"]["publishers"] == ["/fmu_sign_tracking_node"]
    assert run.returncode == 0, stderr
    table = read_csv(out / "results.csv")  # tensor columns are quoted
    end = np.array([table["odometry.posX"][-1], table["odometry.posY"][-1]])
    assert np.linalg.norm(end - GOAL_B) < 0.5
    assert processes_with(str(tmp_path)) == []


def test_images_from_an_rmw_zenoh_client_drive_the_detector_node(
    tmp_path: Path, router: InProcessRouter
) -> None:
    built_model("sign_detector.onnx")
    text = SYSTEM.read_text(encoding="utf-8").replace("../", f"{REPO.as_posix()}/")
    text = text.replace("run: {start: 0, stop: 32,", "run: {start: 0, stop: 6,")
    text = text.replace("    kind: mujoco\n", "    kind: mujoco\n    external: true\n", 1)
    system = tmp_path / "external.yaml"
    system.write_text(text, encoding="utf-8")
    env = zenoh_environment(RosDistro.JAZZY, router=router.endpoint)
    observer = ZenohTransport(env, "/", "test_observer")
    blobs = observer.reader("rt/onnx_blobSize", "std_msgs/msg/Float64MultiArray",
                            PROFILES["default"])  # fmt: skip
    # The camera publishes before the run starts, and until it is stopped: a free run of 6 s
    # is over before a camera started after it (its interpreter, the Zenoh SDK) had sent a
    # frame, on a loaded machine.
    camera = subprocess.Popen(
        [sys.executable, str(PEER), "image-pub", str(router.port), "1000000"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    run = None
    sizes: list[float] = []
    try:
        assert camera.stdout is not None
        assert json.loads(camera.stdout.readline()) == {"ready": True}
        run = subprocess.Popen(
            _zenoh_run(system, tmp_path / "out", "-q", "--no-checks", "--sync", "free",
                       "--zenoh-router", router.endpoint),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        assert observer.graph.wait_for(checker_kind("MS"), "/camera/image_raw", 1, 120.0), (
            "the detector node never subscribed"
        )
        deadline = time.monotonic() + 60
        while not sizes and time.monotonic() < deadline:
            ended = run.poll() is not None
            blobs.wait(0.5)
            for data in blobs.take():
                red = float(deserialize(data, "std_msgs/msg/Float64MultiArray",
                                        RosDistro.JAZZY).data[0])  # fmt: skip
                if red > 0:
                    sizes.append(red)
            if ended:  # what it published before it ended has been taken
                break
        _, stderr = run.communicate(timeout=120)
    finally:
        for process in (run, camera):
            end_process(process)
        observer.close()
    assert sizes, "no detection of the published image reached /onnx_blobSize"
    assert sizes[0] == pytest.approx(282.8427, rel=1e-4)
    assert run is not None
    assert run.returncode == 0, stderr
    assert processes_with(str(tmp_path)) == []


def checker_kind(code: str) -> object:
    """The transport's entity kind of a token code (``MS``)."""
    from fmionnx.backends.ros2.zenoh.keys import EntityKind

    return EntityKind(code)


def _long_zenoh_run(tmp_path: Path) -> tuple[subprocess.Popen[str], str]:
    out = tmp_path / "out"
    process = subprocess.Popen(
        _zenoh_run(loop_system(tmp_path, 10000.0), out),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    wait_for_nodes(str(tmp_path), 3)
    log = out / "logs" / "integ.log"
    deadline = time.monotonic() + 60
    while (not log.exists() or "ready" not in log.read_text()) and time.monotonic() < deadline:
        time.sleep(0.2)
    return process, out.as_posix()


def _router_of(out: str) -> str:
    """The endpoint the supervisor's router listened on (from a node's command line)."""
    for pid in processes_with(out):
        args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        if b"--zenoh-router" in args:
            return args[args.index(b"--zenoh-router") + 1].decode()
    pytest.fail("no node names its router")


def test_ctrl_c_stops_a_zenoh_run_its_nodes_and_its_router(
    tmp_path: Path, zenoh_domain: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    _unused_router(monkeypatch)
    process, out = _long_zenoh_run(tmp_path)
    try:
        endpoint = _router_of(out)
        assert reachable(endpoint)
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        end_process(process)
    assert process.returncode == 130, stderr
    assert stdout.strip().splitlines()[-1] == f"Results: {out}"
    assert processes_with(str(tmp_path)) == []
    assert not reachable(endpoint)


def test_a_killed_zenoh_node_stops_the_run_naming_it_and_leaves_nothing_behind(
    tmp_path: Path, zenoh_domain: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    _unused_router(monkeypatch)
    process, out = _long_zenoh_run(tmp_path)
    try:
        endpoint = _router_of(out)
        victim = next(
            p for p in processes_with(out)
            if b"\0integ\0" in Path(f"/proc/{p}/cmdline").read_bytes()
        )  # fmt: skip
        os.kill(victim, signal.SIGKILL)
        _, stderr = process.communicate(timeout=60)
    finally:
        end_process(process)
    assert process.returncode == 1
    assert "node /integ (component `integ`) was killed by signal 9 (SIGKILL)" in " ".join(
        stderr.split()
    )
    assert processes_with(str(tmp_path)) == []
    assert not reachable(endpoint)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--middleware", "zenoh", "--zenoh-router", "localhost:7447"],
         "--zenoh-router must be `auto` or an endpoint like `tcp/localhost:7447`"),
        (["--zenoh-router", "tcp/localhost:7447"], "--zenoh-router applies to --middleware zenoh"),
    ],
)  # fmt: skip
def test_zenoh_options_are_checked_before_anything_starts(
    tmp_path: Path, args: list[str], message: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    result = CliRunner().invoke(
        app, ["run", str(loop_system(tmp_path, 1.0)), "--backend", "ros2", *args]
    )
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())


def test_a_bad_zenoh_override_ends_the_run_with_one_clear_line(
    tmp_path: Path, zenoh_domain: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", "no/such/key=1")
    done = subprocess.run(
        _zenoh_run(loop_system(tmp_path, 1.0), tmp_path / "out", "-q"),
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 1
    assert "ZENOH_CONFIG_OVERRIDE: `no/such/key=1`: unknown key" in done.stderr
    assert "Traceback" not in done.stderr
    assert processes_with(str(tmp_path)) == []
