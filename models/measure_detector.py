"""Measure the sign detector on frames rendered from the sign course (numbers for its model card).

Frames come from the robot's ``front`` camera at seeded random poses: along each leg of the
expected path, facing the sign that leg approaches (with lateral and heading jitter), plus
poses anywhere in the arena at any heading. For each frame MuJoCo also renders a segmentation
image, which gives the true pixels of each sign board. Reported:

* **ONNX vs numpy**: largest difference between the ONNX model and :func:`numpy_blobs`, the
  plain numpy implementation of the same colour-box measure, rounded to float32 like the
  model's outputs (0 means bit-identical);
* **blobX error vs truth**: |blobX - mean column of the board's pixels| where the board shows
  at least ``MIN_PIXELS`` pixels (0 since the course renders without anti-aliasing; edge
  pixels blended by anti-aliasing made it non-zero);
* **detection rate**: share of those frames in which the detector reports the board's colour;
  **false detections**: frames where the colour is reported but its board shows no pixel.

Usage: ``python models/measure_detector.py [--frames 200] [--seed 1]`` after ``make models``.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
import onnxruntime as ort

HERE = Path(__file__).resolve().parent
SCENE = HERE / "world" / "sign_course.xml"
PATH_CSV = HERE / "world" / "sign_course.path.csv"
DETECTOR = HERE.parent / "build" / "models" / "sign_detector.onnx"
WIDTH, HEIGHT = 640, 480
BOARDS = ("sign_stop_board", "sign_right_board", "sign_left_board")  # red, green, blue
MIN_PIXELS = 50

#: Inclusive RGB boxes of red, green, blue (the original example's thresholds).
BOXES = (
    ((100, 255), (0, 55), (0, 50)),
    ((0, 50), (50, 255), (0, 50)),
    ((0, 40), (0, 55), (50, 255)),
)


def numpy_blobs(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference measure on one ``uint8[H,W,3]`` frame: (blobX[3], blobSize[3]), float64."""
    blob_x = np.full(3, -1.0)
    blob_size = np.zeros(3)
    for colour, box in enumerate(BOXES):
        mask = np.ones(image.shape[:2], bool)
        for channel, (low, high) in enumerate(box):
            mask &= (image[..., channel] >= low) & (image[..., channel] <= high)
        columns = np.nonzero(mask)[1]
        if columns.size:
            blob_x[colour] = columns.mean()
            blob_size[colour] = np.sqrt(2.0 * columns.size)
    return blob_x, blob_size


@dataclass(frozen=True)
class Frame:
    """One rendered view: the RGB image and each board's true pixel columns."""

    pose: tuple[float, float, float]
    image: np.ndarray
    board_columns: tuple[np.ndarray, np.ndarray, np.ndarray]


def sample_poses(count: int, seed: int) -> list[tuple[float, float, float]]:
    """Seeded poses (x, y, heading): 3/4 on the legs facing their sign, 1/4 anywhere."""
    rng = np.random.default_rng(seed)
    path = np.loadtxt(PATH_CSV, delimiter=",", skiprows=1, ndmin=2)
    poses = []
    for k in range(count):
        if k % 4 == 3:
            poses.append(
                (rng.uniform(-1.5, 8.5), rng.uniform(-1.0, 5.3), rng.uniform(-np.pi, np.pi))
            )
            continue
        leg = rng.integers(len(path) - 1)
        a, b = path[leg], path[leg + 1]
        direction = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-direction[1], direction[0]])
        point = a + rng.uniform(0.0, 1.0) * (b - a) + rng.uniform(-0.3, 0.3) * normal
        heading = np.arctan2(direction[1], direction[0]) + rng.uniform(-0.35, 0.35)
        poses.append((float(point[0]), float(point[1]), float(heading)))
    return poses


def render_frames(
    poses: list[tuple[float, float, float]], scene: Path | str = SCENE
) -> Iterator[Frame]:
    """Place the robot at each pose and render the ``front`` camera (RGB + segmentation).

    ``scene``: the scene file, or a scene's XML text (a variant of its visual settings)."""
    if isinstance(scene, Path):
        model = mujoco.MjModel.from_xml_path(str(scene))
    else:
        model = mujoco.MjModel.from_xml_string(scene)
    data = mujoco.MjData(model)
    boards = [model.geom(name).id for name in BOARDS]
    base = model.joint("base").qposadr[0]
    rgb = mujoco.Renderer(model, HEIGHT, WIDTH)
    seg = mujoco.Renderer(model, HEIGHT, WIDTH)
    seg.enable_segmentation_rendering()
    try:
        for x, y, heading in poses:
            data.qpos[base : base + 7] = [
                x,
                y,
                0.05,
                np.cos(heading / 2),
                0,
                0,
                np.sin(heading / 2),
            ]
            mujoco.mj_forward(model, data)
            rgb.update_scene(data, "front")
            seg.update_scene(data, "front")
            image = rgb.render().copy()
            ids = seg.render()
            is_geom = ids[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
            columns = tuple(np.nonzero(is_geom & (ids[..., 0] == g))[1] for g in boards)
            yield Frame((x, y, heading), image, (columns[0], columns[1], columns[2]))
    finally:
        rgb.close()
        seg.close()


def detector_session(path: Path = DETECTOR) -> ort.InferenceSession:
    """The session the reference system's runner creates: one thread (the fastest on 2 shared
    cores, and the parallel master's other core renders meanwhile) and graph optimisation up to
    ``ORT_ENABLE_EXTENDED`` (``ORT_ENABLE_ALL`` adds NCHWc layout reorders that cost ~4x the
    model)."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def measure(frames: int, seed: int, detector: Path = DETECTOR) -> dict[str, float]:
    """Render ``frames`` views and return the accuracy figures described in the module doc."""
    session = detector_session(detector)
    onnx_vs_numpy_x = onnx_vs_numpy_size = 0.0
    errors: list[float] = []
    visible = detected = false_detections = absent = 0
    for frame in render_frames(sample_poses(frames, seed)):
        blob_x, blob_size = session.run(None, {"image": frame.image[np.newaxis]})
        ref_x, ref_size = (r.astype(np.float32) for r in numpy_blobs(frame.image))
        onnx_vs_numpy_x = max(onnx_vs_numpy_x, float(np.abs(blob_x[0] - ref_x).max()))
        onnx_vs_numpy_size = max(onnx_vs_numpy_size, float(np.abs(blob_size[0] - ref_size).max()))
        for colour, columns in enumerate(frame.board_columns):
            seen = blob_size[0, colour] > 0
            if columns.size >= MIN_PIXELS:
                visible += 1
                detected += int(seen)
                if seen:
                    errors.append(abs(float(blob_x[0, colour]) - float(columns.mean())))
            elif columns.size == 0:
                absent += 1
                false_detections += int(seen)
    err = np.array(errors) if errors else np.zeros(1)
    return {
        "frames": float(frames),
        "onnx_vs_numpy_blobX_max_px": onnx_vs_numpy_x,
        "onnx_vs_numpy_blobSize_max": onnx_vs_numpy_size,
        "boards_visible": float(visible),
        "detection_rate": detected / visible if visible else float("nan"),
        "blobX_error_mean_px": float(err.mean()),
        "blobX_error_p95_px": float(np.percentile(err, 95)),
        "blobX_error_max_px": float(err.max()),
        "boards_absent": float(absent),
        "false_detection_rate": false_detections / absent if absent else float("nan"),
    }


def main(argv: list[str] | None = None) -> int:
    """Print the figures as a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    results = measure(args.frames, args.seed)
    print(f"| measure (seed {args.seed}) | value |\n|---|---|")
    for key, value in results.items():
        print(f"| {key} | {value:.4g} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
