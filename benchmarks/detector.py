"""The sign detector against plain numpy, and what the camera's rendering costs (issue 14).

Side by side in one run, on the same frames rendered from the sign course's ``front`` camera
at seeded poses (``models/measure_detector.py``):

1. **Detector per frame**: the ONNX model as ``make models`` built it, in the session
   fmionnx's runner creates (``ORT_ENABLE_EXTENDED``, the system file's ``threads: 1``), with
   two intra-op threads, and at onnxruntime's default level (``ORT_ENABLE_ALL``); against the
   same colour-blob measure in plain numpy, twice: ``measure_detector.numpy_blobs`` (the
   accuracy tests' reference) and :func:`numpy_blobs_fast` (each distinct bound compared once,
   per-column counts, no ``nonzero``). Every contender runs on every frame in turn, for several
   rounds; the table gives the median per frame, and every contender's outputs are checked
   equal to the reference's (rounded to float32, as the model's). Ratios are paired: per frame
   and round, a contender's time over the fastest numpy's on the same frame in the same pass
   (the contenders' order rotates from frame to frame, so that none is always the first to
   touch a frame, which finds it colder in the cache); the table gives their median (and min / min, the uncontended case). Target: the runner's
   session / the fastest numpy <= 1.0.
2. **Render per frame**: ``update_scene`` + ``render`` of the 640x480 camera with the scene's
   visual settings before issue 14 (anti-aliasing, skybox, floor texture, second light:
   ``measure_rendering.before_scene``) and as committed, interleaved pose by pose.
3. **What each visual setting costs** (not with ``--quick``): ``measure_rendering.measure``,
   each setting turned on in the committed scene, with its effect on the detector's accuracy.

Targets are reported, not asserted. Run: ``python benchmarks/detector.py`` (about a minute on
2 cores) after ``make models``; ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable
if str(REPO / "models") not in sys.path:
    sys.path.insert(0, str(REPO / "models"))  # the measuring scripts next to the models

os.environ.setdefault("MUJOCO_GL", "egl")  # as the other benchmarks do; set before mujoco loads

import measure_detector as md  # noqa: E402
import measure_rendering as mr  # noqa: E402
import numpy as np  # noqa: E402
import onnxruntime as ort  # noqa: E402
from rich.console import Console  # noqa: E402

from benchmarks import machine, report  # noqa: E402

RUNNER = "onnx, runner's session (EXTENDED, 1 thread)"
TWO_THREADS = "onnx, EXTENDED, 2 threads"
DEFAULT_LEVEL = "onnx, onnxruntime default (ALL), 1 thread"
NUMPY_REFERENCE = "numpy, measure_detector.numpy_blobs"
NUMPY_FAST = "numpy, numpy_blobs_fast"
NUMPYS = (NUMPY_REFERENCE, NUMPY_FAST)
DETECTOR_TARGET = 1.0
COLUMNS = np.arange(md.WIDTH, dtype=np.float64)

Blobs = tuple[np.ndarray, np.ndarray]

DETECTOR_COLUMNS = (
    ("contender", "implementation"),
    ("median_ms", "ms/frame (median)"),
    ("min_ms", "ms/frame (min)"),
    ("vs_numpy", "x fastest numpy (median of per-frame ratios)"),
    ("min_vs_numpy", "x fastest numpy (min / min)"),
    ("correct", "= numpy"),
)
RENDER_COLUMNS = (
    ("scene", "scene"),
    ("median_ms", "ms/frame (median)"),
    ("vs_before", "x before"),
)
SETTING_COLUMNS = (
    ("setting", "setting (turned on)"),
    ("off_ms", "ms without"),
    ("on_ms", "ms with"),
    ("cost_ms", "cost ms"),
    ("changed_pct", "% pixels changed"),
    ("detection", "detection rate with"),
    ("error_px", "max blobX error with, px"),
    ("false", "false detections with"),
)


def numpy_blobs_fast(image: np.ndarray) -> Blobs:
    """The colour-blob measure in plain numpy, written for speed: each distinct bound is
    compared once over its channel, colour masks are their AND, per-column counts give the
    count and the column sum. Same results as ``numpy_blobs`` (rounded to float32)."""
    tests: dict[tuple[int, int, int], np.ndarray] = {}

    def holds(channel: int, sign: int, threshold: int) -> np.ndarray:
        key = (channel, sign, threshold)
        if key not in tests:
            plane = image[..., channel]
            tests[key] = plane >= threshold if sign > 0 else plane <= threshold
        return tests[key]

    blob_x = np.full(3, -1.0)
    blob_size = np.zeros(3)
    for colour, box in enumerate(md.BOXES):
        bounds = [(c, 1, low) for c, (low, _) in enumerate(box) if low > 0]
        bounds += [(c, -1, high) for c, (_, high) in enumerate(box) if high < 255]
        mask = holds(*bounds[0])
        for bound in bounds[1:]:
            mask = mask & holds(*bound)
        per_column = np.count_nonzero(mask, axis=0)
        count = int(per_column.sum())
        if count:
            blob_x[colour] = float(per_column @ COLUMNS) / count
            blob_size[colour] = np.sqrt(2.0 * count)
    return blob_x, blob_size


def session(level: ort.GraphOptimizationLevel, threads: int) -> ort.InferenceSession:
    """A CPU session on the built detector."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.graph_optimization_level = level
    return ort.InferenceSession(str(md.DETECTOR), options, providers=["CPUExecutionProvider"])


def contenders() -> dict[str, Callable[[np.ndarray], Blobs]]:
    """Each implementation as a function of one frame."""

    def onnx(s: ort.InferenceSession) -> Callable[[np.ndarray], Blobs]:
        def run(image: np.ndarray) -> Blobs:
            blob_x, blob_size = s.run(None, {"image": image[np.newaxis]})
            return blob_x[0], blob_size[0]

        return run

    extended = ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED
    return {
        RUNNER: onnx(session(extended, 1)),
        TWO_THREADS: onnx(session(extended, 2)),
        DEFAULT_LEVEL: onnx(session(ort.GraphOptimizationLevel.ORT_ENABLE_ALL, 1)),
        NUMPY_REFERENCE: md.numpy_blobs,
        NUMPY_FAST: numpy_blobs_fast,
    }


def same(a: Blobs, b: Blobs) -> bool:
    """Equal once rounded to float32 (the model's output type)."""
    return all(np.array_equal(np.float32(x), np.float32(y)) for x, y in zip(a, b, strict=True))


def detector_rows(frames: Sequence[np.ndarray], rounds: int) -> list[dict[str, Any]]:
    """Time every contender on every frame, interleaved; rows with medians and ratios."""
    runs = contenders()
    correct = dict.fromkeys(runs, True)
    for name, run in runs.items():  # warm-up (session arenas, first-call costs), and checked
        for frame in frames:
            correct[name] &= same(run(frame), md.numpy_blobs(frame))
    names = list(runs)
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(rounds):
        for index, frame in enumerate(frames):
            # rotate who goes first: the first call on a frame finds it colder in the cache
            for name in names[index % len(names) :] + names[: index % len(names)]:
                run = runs[name]
                started = time.perf_counter()
                run(frame)
                times[name].append(time.perf_counter() - started)
    medians = {name: 1e3 * statistics.median(t) for name, t in times.items()}
    fastest = min(NUMPYS, key=lambda name: medians[name])
    baseline = np.array(times[fastest])
    return [
        {
            "contender": name,
            "median_ms": medians[name],
            "min_ms": 1e3 * min(times[name]),
            # paired: the calls on the same frame in the same pass see about the same machine
            # load; the median of those ratios is steadier than a ratio of medians
            "vs_numpy": float(np.median(np.array(times[name]) / baseline)),
            "min_vs_numpy": min(times[name]) / float(baseline.min()),
            "correct": correct[name],
        }
        for name in runs
    ]


def render_rows(poses: Sequence[tuple[float, float, float]], repeats: int) -> list[dict[str, Any]]:
    """Render time per frame with the scene's visual settings before issue 14 and now."""
    variants = mr.time_variants(
        {"before (issue 14)": mr.before_scene(), "committed": mr.scene_text()}, poses, repeats
    )
    before = variants["before (issue 14)"].median_ms()
    return [
        {"scene": name, "median_ms": v.median_ms(), "vs_before": v.median_ms() / before}
        for name, v in variants.items()
    ]


def setting_rows(frames: int, seed: int, repeats: int) -> list[dict[str, Any]]:
    """Each visual setting turned on in the committed scene: cost and effect."""
    return [
        {
            "setting": c.setting,
            "off_ms": c.off_ms,
            "on_ms": c.on_ms,
            "cost_ms": c.on_ms - c.off_ms,
            "changed_pct": 100 * c.changed_pixels,
            "detection": c.accuracy_on["detection_rate"],
            "error_px": c.accuracy_on["blobX_error_max_px"],
            "false": int(c.accuracy_on["false_detections"]),
        }
        for c in mr.measure(frames, seed, repeats=repeats)
    ]


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command-line options."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40, help="rendered frames")
    parser.add_argument("--rounds", type=int, default=5, help="timed passes over the frames")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="tiny sizes, no settings table")
    args = parser.parse_args(argv)
    if args.quick:
        args.frames, args.rounds = 4, 1
    return args


def main(argv: Sequence[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure, print the tables; returns the rows and targets (what the tables show)."""
    args = parse(argv)
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    info = machine.describe()
    results: dict[str, Any] = {"gl": f"MUJOCO_GL={os.environ['MUJOCO_GL']}, {mr.gl_renderer()}"}
    console.print(
        machine.headline("fmionnx sign detector and camera rendering", info) + f"; {results['gl']}"
    )
    missing = [p.name for p in (md.DETECTOR,) if not p.exists()]
    if missing:
        console.print(f"skipped: run `make models` first; missing {missing}")
        return {"skipped": missing}
    poses = md.sample_poses(args.frames, args.seed)
    frames = [frame.image for frame in md.render_frames(poses)]
    results["detector"] = detector_rows(frames, args.rounds)
    report.print_table(
        console,
        f"Detector per 640x480 frame, {len(frames)} rendered frames x {args.rounds} interleaved "
        "rounds",
        DETECTOR_COLUMNS,
        results["detector"],
    )
    results["render"] = render_rows(poses, max(1, args.rounds // 2))
    report.print_table(
        console,
        "Render per frame (update_scene + render), interleaved",
        RENDER_COLUMNS,
        results["render"],
    )
    if not args.quick:
        results["settings"] = setting_rows(args.frames, args.seed, max(1, args.rounds // 2))
        report.print_table(
            console,
            "What each visual setting costs, turned on in the committed scene",
            SETTING_COLUMNS,
            results["settings"],
        )
    ratio = next(r["vs_numpy"] for r in results["detector"] if r["contender"] == RUNNER)
    results["targets"] = [
        {
            "target": "detector per frame / fastest numpy",
            "value": ratio,
            "limit": f"<= {DETECTOR_TARGET:g}",
            "met": ratio <= DETECTOR_TARGET,
        }
    ]
    report.print_table(
        console, "Targets (reported, not asserted)", report.TARGET_COLUMNS, results["targets"]
    )
    return results


if __name__ == "__main__":
    main()
