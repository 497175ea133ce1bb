"""The reference robot as ROS 2 nodes: lockstep equals in-process bit for bit, a free run
reaches B, an independent DDS subscriber gets ``/cmd_vel``, outside images drive the detector."""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from fmionnx.backends.ros2.codec import WHOLE, PortField, TopicCodec
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES
from fmionnx.results.csvfile import read_csv
from tests.conftest import REPO, built_model, end_process
from tests.ros2.test_run import fmionnx, processes_with
from tests.ros2.test_wire import PEERS

pytestmark = pytest.mark.ros2

SYSTEM = REPO / "systems" / "sign_follower.yaml"
GOAL_B = np.array([6.0, 3.0])


def _csv(path: Path) -> dict[str, np.ndarray]:
    return read_csv(path)  # tensor columns are quoted (`"detector.blobX[0,2]"`)


def _inprocess_csv(folder: Path, stop: str) -> bytes:
    built_model("ReadOdometry.fmu")  # raises with a `make models` hint when missing
    subprocess.run(
        fmionnx("run", SYSTEM, "-q", "--stop-time", stop, *_checks(stop), "--out", folder),
        check=True,
        timeout=180,
    )
    return (folder / "results.csv").read_bytes()


def _checks(stop: str) -> list[str]:
    """The system's checks judge the whole run (B reached, the robot stopped)."""
    return [] if stop == "32" else ["--no-checks"]


# The first 12 s hold every state of the tracker (the search, the turn and approach at A, the
# stop, the cruise towards B); the whole 32 s run, 2.7 times the work, runs in `make soak`.
@pytest.mark.parametrize("stop", ["12", pytest.param("32", marks=pytest.mark.slow)])
def test_lockstep_reference_run_equals_inprocess_and_feeds_an_independent_cmd_vel_subscriber(
    tmp_path: Path, loopback_env, stop: str
) -> None:
    inprocess_csv = _inprocess_csv(tmp_path / "inprocess", stop)
    subscriber = subprocess.Popen(
        [*fmionnx()[:1], str(PEERS), "twist-sub", "200", "--until-eof"],
        stdin=subprocess.PIPE,  # closed by communicate() once the run is over
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert subscriber.stdout is not None
        assert json.loads(subscriber.stdout.readline()) == {"ready": True}
        out = tmp_path / "ros2"
        done = subprocess.run(
            fmionnx(
                "run",
                SYSTEM,
                "-q",
                "--backend",
                "ros2",
                "--sync",
                "lockstep",
                "--out",
                out,
                "--stop-time",
                stop,
                *_checks(stop),
                "--ros-distro",
                "humble",
            ),  # the peer's Cyclone settings are Humble's
            capture_output=True,
            text=True,
            timeout=240,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        received, _ = subscriber.communicate(timeout=30)
    finally:
        end_process(subscriber)
    assert (out / "results.csv").read_bytes() == inprocess_csv
    commands = [json.loads(line) for line in received.splitlines()]
    assert len(commands) >= 200
    assert {c["x"] for c in commands} <= {0.0, 0.4, 0.5}  # stopped, approach, cruise
    assert max(c["x"] for c in commands) > 0
    assert processes_with(str(tmp_path)) == []


def test_free_run_of_the_reference_system_reaches_b_within_half_a_metre(
    tmp_path: Path, loopback_env
) -> None:
    built_model("ReadOdometry.fmu")
    out = tmp_path / "free"
    done = subprocess.run(
        fmionnx("run", SYSTEM, "-q", "--backend", "ros2", "--sync", "free", "--rtf", "1.5",
                "--out", out, "--ros-distro", "humble"),
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    table = _csv(out / "results.csv")
    end = np.array([table["odometry.posX"][-1], table["odometry.posY"][-1]])
    assert np.linalg.norm(end - GOAL_B) < 0.5
    assert table["tracker.v"][-1] == 0.0
    assert processes_with(str(tmp_path)) == []


def test_outside_images_on_camera_image_raw_drive_the_detector_when_the_world_is_external(
    tmp_path: Path, loopback_env
) -> None:
    built_model("sign_detector.onnx")
    text = SYSTEM.read_text(encoding="utf-8").replace("../", f"{REPO.as_posix()}/")
    text = text.replace("run: {start: 0, stop: 32,", "run: {start: 0, stop: 6,")
    text = text.replace("    kind: mujoco\n", "    kind: mujoco\n    external: true\n", 1)
    system = tmp_path / "external.yaml"
    system.write_text(text, encoding="utf-8")
    participant = Participant(from_environment(RosDistro.HUMBLE))
    image_type, blob_type = "sensor_msgs/msg/Image", "std_msgs/msg/Float64MultiArray"
    camera = participant.writer("rt/camera/image_raw", image_type, PROFILES["default"])
    blobs = participant.reader("rt/onnx_blobSize", blob_type, PROFILES["default"])
    image_codec = TopicCodec(image_type, (PortField("front", (WHOLE,), (480, 640, 3), "uint8"),),
                             RosDistro.HUMBLE)  # fmt: skip
    blob_codec = TopicCodec(
        blob_type, (PortField("blobSize", ("data",), (1, 3)),), RosDistro.HUMBLE
    )
    frame = np.full((480, 640, 3), 128, dtype=np.uint8)
    frame[100:300, 200:400] = (220, 20, 20)  # a red board
    run = subprocess.Popen(
        fmionnx("run", system, "--no-checks", "-q", "--backend", "ros2", "--sync", "free", "--out",
                tmp_path / "out", "--ros-distro", "humble"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    sizes: list[float] = []
    try:
        assert camera.wait_for_readers(1, 120.0), "the detector node never subscribed"
        deadline = time.monotonic() + 60
        while not sizes and time.monotonic() < deadline and run.poll() is None:
            camera.write(image_codec.encode({"front": frame}))
            time.sleep(0.1)
            for data in blobs.take():
                red = float(blob_codec.decode(data)[0]["blobSize"][0])
                if red > 0:
                    sizes.append(red)
        _, stderr = run.communicate(timeout=120)
    finally:
        end_process(run)
        participant.close()
    assert sizes, "no detection of the published image reached /onnx_blobSize"
    assert sizes[0] == pytest.approx(282.8427, rel=1e-4)
    assert run.returncode == 0, stderr
    assert processes_with(str(tmp_path)) == []
