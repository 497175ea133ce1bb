"""The reference scenario as a plain hand-written closed loop: the baseline fmionnx is measured by.

It makes exactly the calls a co-simulation master must make and nothing else: fmpy
``FMU2Slave`` for the two FMUs, one onnxruntime session for the detector, MuJoCo with an
offscreen ``Renderer`` for the world. Rates are those of ``systems/sign_follower.yaml``:

* physics every ``PHYSICS_STEP`` (0.002 s),
* ReadOdometry and SignTrackingLogic every ``CONTROL_PERIOD`` (0.01 s),
* camera frame + detector every ``CAMERA_PERIOD`` (0.1 s).

Order at a control tick t (sample and hold): read the sensors at t; if due, render and detect;
odometry (inputs, outputs: direct feedthrough, then doStep); tracker (inputs, doStep(t, h),
outputs); the commands then hold over the physics steps up to t + h. The run is deterministic:
MuJoCo is, and the ONNX session runs on one thread.

Run as a script to print a summary and write ``trajectory.csv``:
``python benchmarks/handwritten_sign_follower.py [--stop 40] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
import onnxruntime as ort
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

REPO = Path(__file__).resolve().parent.parent
MODELS = REPO / "build" / "models"
SCENE = REPO / "models" / "world" / "sign_course.xml"
EXPECTED_PATH = REPO / "models" / "world" / "sign_course.path.csv"

PHYSICS_STEP = 0.002
CONTROL_PERIOD = 0.01
CAMERA_PERIOD = 0.1
WIDTH, HEIGHT = 640, 480
STOP_TIME = 40.0

#: Recorded signals, one row per control tick.
SIGNALS = ("time", "posX", "posY", "theta", "v", "w", "state", "stopRobot")


class Fmu:
    """One co-simulation FMU: extracted, instantiated, initialised; values by variable name."""

    def __init__(self, path: Path, instance: str, parameters: dict[str, float] | None = None):
        self.description = read_model_description(str(path))
        self.unzipped = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.slave = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.unzipped,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=instance,
        )
        self.slave.instantiate()
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        if parameters:
            self.slave.setReal([self.vr[n] for n in parameters], list(parameters.values()))
        self.slave.exitInitializationMode()

    def refs(self, *names: str) -> list[int]:
        """Value references of ``names``, looked up once by the caller."""
        return [self.vr[n] for n in names]

    def close(self) -> None:
        """Terminate, free and delete the extracted files."""
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


def run(stop_time: float = STOP_TIME, models: Path = MODELS) -> dict[str, np.ndarray]:
    """Simulate the sign course until ``stop_time``; return the recorded signals.

    Keys: the names in :data:`SIGNALS` (1-D, one entry per control tick), ``blobX`` and
    ``blobSize`` ((n, 3), as the tracker saw them) and ``wall_time`` (seconds, a 0-d array).
    """
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    model.opt.timestep = PHYSICS_STEP
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, HEIGHT, WIDTH)
    camera = model.camera("front").id
    pos_adr = model.sensor("base_pos").adr[0]
    quat_adr = model.sensor("base_quat").adr[0]
    cmd_v, cmd_w = model.actuator("cmd_v").id, model.actuator("cmd_w").id

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    # as fmionnx's ONNX runner: the ALL level's NCHWc reorders cost ~4x this model
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED
    detector = ort.InferenceSession(
        str(models / "sign_detector.onnx"), options, providers=["CPUExecutionProvider"]
    )

    odometry = Fmu(models / "ReadOdometry.fmu", "odometry")
    tracker = Fmu(models / "SignTrackingLogic.fmu", "tracker")
    odo_in = odometry.refs("qw", "qx", "qy", "qz", "x", "y")
    odo_out = odometry.refs("posX", "posY", "theta")
    blob_refs = tracker.refs(
        *(f"blobSize[{i}]" for i in (1, 2, 3)), *(f"blobX[{i}]" for i in (1, 2, 3))
    )
    pose_refs = tracker.refs("posX", "posY", "theta")
    vw_refs = tracker.refs("v", "w")
    (state_ref,) = tracker.refs("state")
    (stop_ref,) = tracker.refs("stopRobot")

    ticks = round(stop_time / CONTROL_PERIOD)
    substeps = round(CONTROL_PERIOD / PHYSICS_STEP)
    frame_every = round(CAMERA_PERIOD / CONTROL_PERIOD)
    rows = np.zeros((ticks, len(SIGNALS)))
    blobs = np.zeros((ticks, 6))
    blob_values = [0.0, 0.0, 0.0, -1.0, -1.0, -1.0]
    mujoco.mj_forward(model, data)
    started = time.perf_counter()
    try:
        for tick in range(ticks):
            t = tick * CONTROL_PERIOD
            if tick % frame_every == 0:
                renderer.update_scene(data, camera)
                frame = renderer.render()
                blob_x, blob_size = detector.run(None, {"image": frame[np.newaxis]})
                blob_values = [*blob_size[0].tolist(), *blob_x[0].tolist()]
            sensors = data.sensordata
            quat = sensors[quat_adr : quat_adr + 4]
            pos = sensors[pos_adr : pos_adr + 2]
            odometry.slave.setReal(odo_in, [*quat.tolist(), *pos.tolist()])
            pose = odometry.slave.getReal(odo_out)
            odometry.slave.doStep(t, CONTROL_PERIOD)

            tracker.slave.setReal(blob_refs, blob_values)
            tracker.slave.setReal(pose_refs, pose)
            tracker.slave.doStep(t, CONTROL_PERIOD)
            v, w = tracker.slave.getReal(vw_refs)
            state = tracker.slave.getInteger([state_ref])[0]
            stop = tracker.slave.getBoolean([stop_ref])[0]

            data.ctrl[cmd_v] = v
            data.ctrl[cmd_w] = w
            for _ in range(substeps):
                mujoco.mj_step(model, data)
            rows[tick] = (t, *pose, v, w, state, float(stop))
            blobs[tick] = blob_values
    finally:
        odometry.close()
        tracker.close()
        renderer.close()
    result = {name: rows[:, k] for k, name in enumerate(SIGNALS)}
    result["blobSize"] = blobs[:, :3]
    result["blobX"] = blobs[:, 3:]
    result["wall_time"] = np.array(time.perf_counter() - started)
    return result


def expected_path() -> np.ndarray:
    """The course's expected path, (n, 2) vertices of a polyline."""
    return np.loadtxt(EXPECTED_PATH, delimiter=",", skiprows=1, ndmin=2)


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 2) to the polyline ``path`` (m, 2)."""
    best = np.full(len(points), np.inf)
    for a, b in itertools.pairwise(path):
        ab = b - a
        s = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + s[:, None] * ab), axis=1))
    return best


def summary(result: dict[str, np.ndarray]) -> dict[str, float]:
    """Goal distance at the end, largest path deviation, turns taken, time of the stop."""
    xy = np.stack([result["posX"], result["posY"]], axis=1)
    path = expected_path()
    states = result["state"]
    stopped = np.flatnonzero(result["stopRobot"] > 0)
    return {
        "goal_distance": float(np.linalg.norm(xy[-1] - path[-1])),
        "max_path_deviation": float(distance_to_path(xy, path).max()),
        "left_turns": float(np.count_nonzero(np.diff((states == 2).astype(int)) == 1)),
        "right_turns": float(np.count_nonzero(np.diff((states == 3).astype(int)) == 1)),
        "stop_time": float(result["time"][stopped[0]]) if len(stopped) else float("nan"),
        "wall_time": float(result["wall_time"]),
    }


def main(argv: list[str] | None = None) -> int:
    """Command line: run, print the summary, write ``trajectory.csv``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop", type=float, default=STOP_TIME)
    parser.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()))
    args = parser.parse_args(argv)
    result = run(args.stop)
    for key, value in summary(result).items():
        print(f"{key:20s} {value:.4f}")
    args.out.mkdir(parents=True, exist_ok=True)
    table = np.column_stack([result[name] for name in SIGNALS])
    np.savetxt(
        args.out / "trajectory.csv",
        table,
        delimiter=",",
        header=",".join(SIGNALS),
        comments="",
        fmt="%.9g",
    )
    print(f"wrote {args.out / 'trajectory.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
