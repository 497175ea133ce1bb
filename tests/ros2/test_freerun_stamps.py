"""A free run whose camera frames arrive well after ``/clock`` passed their time.

The world node publishes its camera on ``/camera/raw_early`` (``fmionnx node --remap``); a
relay process (``relay_peer.py``) republishes each frame 0.2 s later on ``/camera/image_raw``,
where the detector reads it, with a red square whose size names the frame. Which frame the
detector stepped on is then read from its own recorded output, independently of the node's
bookkeeping: with a wait longer than the hold it is always the frame of its own time; with a
shorter wait the steps go stale (never onto a frame from the future) and ``run.json`` counts
them. Real processes, real Cyclone DDS, the real detector model.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fmionnx import api
from fmionnx.backends.ros2.node import SyncMode
from fmionnx.backends.ros2.supervisor import Ros2Options, Supervisor
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.results.runinfo import write_run_json
from fmionnx.runtime.result import RunStatus
from tests.conftest import REPO, built_model
from tests.ros2.relay_peer import painted, side_of
from tests.ros2.test_run import loop_system, processes_with

pytestmark = pytest.mark.ros2

SYSTEM = REPO / "systems" / "sign_follower.yaml"
RELAY = Path(__file__).with_name("relay_peer.py")
HOLD = 0.2
STOP = 3.0
CAMERA = "/camera/image_raw"


class RelayedCamera(Supervisor):
    """The supervisor of the run, with the world's camera remapped to the relay's input."""

    def argv(self, component: str) -> list[str]:
        argv = super().argv(component)
        if component == "world":
            argv += ["--remap", f"{CAMERA}:=/camera/raw_early"]
        return argv


@pytest.fixture
def relay(loopback_env) -> Iterator[subprocess.Popen[str]]:
    """The relay process, subscribed before the nodes start; always ended."""
    process = subprocess.Popen(
        [sys.executable, str(RELAY), "/camera/raw_early", CAMERA, str(HOLD)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert json.loads(process.stdout.readline()) == {"ready": True}
    yield process
    if process.poll() is None:
        process.kill()
    process.communicate(timeout=30)


def _free_run(folder: Path, input_wait: float) -> tuple[CompiledSystem, dict[str, Any]]:
    """A free run of the reference system for STOP s; its run.json document."""
    built_model("sign_detector.onnx")
    built_model("ReadOdometry.fmu")
    system = api.load(SYSTEM).with_overrides(stop_time=STOP).compiled
    # Humble, as the relay and this session's other in-process participants of the domain
    options = Ros2Options(
        sync=SyncMode.FREE, out=folder, input_wait=input_wait, distro=RosDistro.HUMBLE
    )
    result = RelayedCamera(system, options, folder).run()
    assert result.status is RunStatus.COMPLETED, result.error
    run_json = write_run_json(result, system, folder / "run.json")
    return system, json.loads(run_json.read_text(encoding="utf-8"))


def _detections(folder: Path) -> np.ndarray:
    """The detector's recorded blobSize after each of its steps (row k: step k)."""
    with np.load(folder / "nodes" / "detector.npz") as data:
        columns = [str(c) for c in data["columns0"]]
        rows = np.asarray(data["rows0"])
    wanted = [i for i, c in enumerate(columns) if c.startswith("detector.blobSize")]
    return rows[1:, wanted]  # row 0: the outputs after set-up


def _frames_used(detections: np.ndarray) -> list[int | None]:
    """Which painted frame (mod 15) produced each detection, by running the same model here."""
    import onnxruntime as ort

    session = ort.InferenceSession(str(built_model("sign_detector.onnx")))
    name = session.get_inputs()[0].name
    outputs = [o.name for o in session.get_outputs()]
    sizes = {}
    for frame in range(15):
        result = dict(zip(outputs, session.run(None, {name: painted(frame)[None]}), strict=True))
        sizes[frame] = np.asarray(result["blobSize"], dtype=np.float64).reshape(-1)
    used: list[int | None] = []
    for row in detections:
        found = [f for f, size in sizes.items() if np.allclose(row, size, rtol=1e-5)]
        used.append(found[0] if found else None)
    return used


def test_the_detector_steps_on_the_frame_of_its_own_time_behind_a_delaying_relay(
    tmp_path: Path, relay: subprocess.Popen[str]
) -> None:
    _, info = _free_run(tmp_path, input_wait=2.0)
    used = _frames_used(_detections(tmp_path))
    steps = round(STOP / 0.1)
    assert len(used) == steps
    assert used == [k % 15 for k in range(steps)]  # step k: the frame rendered at step k
    counts = info["execution"]["inputs"]["detector"][CAMERA]
    assert counts["match"] == "header"
    assert (counts["matched"], counts["stale"], counts["dropped"]) == (steps, 0, 0)
    assert info["execution"]["input_wait"] == 2.0
    assert processes_with(str(tmp_path)) == []


def test_a_wait_shorter_than_the_delay_makes_stale_steps_never_future_ones_and_counts_them(
    tmp_path: Path, relay: subprocess.Popen[str]
) -> None:
    _, info = _free_run(tmp_path, input_wait=0.02)
    used = _frames_used(_detections(tmp_path))
    steps = round(STOP / 0.1)
    counts = info["execution"]["inputs"]["detector"][CAMERA]
    assert counts["matched"] + counts["stale"] <= steps
    assert counts["stale"] >= 3  # typically 25 of 30: the frames come 0.2 s late
    # every detector step expects another frame: the frame of each stale step that waited
    # came late or never; a step while the camera was silent (no frame since the last stale
    # step) waited for nothing and expects no frame, so it is stale only
    assert 1 <= counts["late"] + counts["dropped"] <= counts["stale"]
    own = [k % 15 for k in range(steps)]
    on_time = sum(u == o for u, o in zip(used, own, strict=True))
    assert on_time <= steps - counts["stale"] + 1
    for k, frame in enumerate(used):  # an older frame (held values), never a future one
        if frame is not None and frame != own[k]:
            assert any(frame == (k - back) % 15 for back in range(1, 8)), (k, frame)
    assert side_of(0) != side_of(1)
    assert processes_with(str(tmp_path)) == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "--backend", "ros2", "--input-wait", "1"], "--input-wait applies to"),
        (["run", "--input-wait", "1"], "--input-wait applies to"),
        (["run", "--backend", "ros2", "--sync", "free", "--input-wait", "-1"], "must be >= 0"),
        (["run", "--backend", "ros2", "--sync", "free", "--input-wait", "nan"], "must be >= 0"),
        (["node", "COMPONENT", "--input-wait", "inf"], "--input-wait must be >= 0 seconds"),
        (["node", "COMPONENT", "--remap", "/a=/b"], "--remap `/a=/b` must look like"),
        (["node", "COMPONENT", "--remap", "/a:=b c"], "`b c` is no topic name"),
    ],
)
def test_free_run_options_are_checked_before_anything_starts(
    tmp_path: Path, args: list[str], message: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    system = str(loop_system(tmp_path, 1.0))
    command, *rest = args
    argv = [command, system, *(["integ" if a == "COMPONENT" else a for a in rest])]
    result = CliRunner().invoke(app, argv)
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split())
    assert not (tmp_path / "out").exists()
