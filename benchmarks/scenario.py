"""The reference scenario: real-time factor of ``systems/sign_follower.yaml`` and where time goes.

Three measurements of the stepping loop (setup such as GL contexts and ONNX sessions excluded):

* **real-time factor**: the in-process run as ``fmionnx run`` does it (default recording),
  interleaved with the hand-written closed loop ``benchmarks/handwritten_sign_follower.py``
  (the same calls with no master around them); medians;
* **timers**: one run whose runners' ``step``/``produce`` are wrapped in ``perf_counter``
  timers, so each category is measured directly: physics (MuJoCo runner step), rendering
  (camera ``produce``), inference (ONNX runner step), FMUs (FMU runner steps: the FMI calls
  and the runner's code around them; for FMUs the native kernel steps, the group's step, which
  includes their transfers); *master* is the rest of the loop (schedule, transfers,
  recording, the timers' own calls);
* **profile**: one cProfile run of the loop, self time grouped by module into the same
  categories; a builtin (numpy, ``isnan``...) is charged to the module that called it.

The timers are the numbers to trust (cProfile adds a cost to every Python call, inflating the
master and the runners' Python code); the profile shows *which* functions the time is in.
"""

from __future__ import annotations

import cProfile
import pstats
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
SYSTEM = REPO / "systems" / "sign_follower.yaml"
MODELS = REPO / "build" / "models"

PHYSICS = "physics (MuJoCo)"
RENDERING = "rendering (camera)"
INFERENCE = "inference (ONNX)"
FMUS = "FMUs"
MASTER = "master"
OTHER = "other"
CATEGORIES = (PHYSICS, RENDERING, INFERENCE, FMUS, MASTER, OTHER)

#: Per component kind: category of ``step`` and of ``produce`` (lazy outputs: cameras).
KIND_CATEGORIES = {
    "mujoco": (PHYSICS, RENDERING),
    "onnx": (INFERENCE, INFERENCE),
    "fmu": (FMUS, FMUS),
}


def missing_models() -> list[str]:
    """Models ``make models`` builds that the scenario needs and that are not there."""
    needed = ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx")
    return [name for name in needed if not (MODELS / name).exists()]


def load_system(stop_time: float | None = None) -> Any:
    """The compiled reference system (``fmionnx.System``), optionally with another stop time."""
    import fmionnx

    system = fmionnx.load(SYSTEM)
    return system.with_overrides(stop_time=stop_time) if stop_time is not None else system


# -- real-time factor ------------------------------------------------------------------------


@dataclass
class RealTime:
    """Loop wall times of both implementations over the same simulated time."""

    simulated: float
    fmionnx: list[float] = field(default_factory=list)
    handwritten: list[float] = field(default_factory=list)
    fmionnx_goal_distance: float = float("nan")
    handwritten_goal_distance: float = float("nan")

    @staticmethod
    def factor(walls: list[float], simulated: float) -> float:
        """Median real-time factor (simulated seconds per wall second)."""
        return simulated / statistics.median(walls) if walls else float("nan")


def _goal_distance(x: float, y: float) -> float:
    from benchmarks import handwritten_sign_follower as hand

    end = hand.expected_path()[-1]
    return float(((x - end[0]) ** 2 + (y - end[1]) ** 2) ** 0.5)


def real_time(stop_time: float | None, repeats: int) -> RealTime:
    """Interleaved runs of fmionnx and the hand-written loop; loop wall times only."""
    from benchmarks import handwritten_sign_follower as hand
    from fmionnx.runtime.result import RunStatus

    system = load_system(stop_time)
    stop = float(system.compiled.run.stop)
    outcome = RealTime(stop)
    for round_ in range(repeats):
        first_fmionnx = round_ % 2 == 0
        for which in ("fmionnx", "hand") if first_fmionnx else ("hand", "fmionnx"):
            if which == "fmionnx":
                result = system.run()
                if result.status is not RunStatus.COMPLETED:
                    msg = f"sign_follower run ended {result.status}: {result.error}"
                    raise RuntimeError(msg)
                outcome.fmionnx.append(result.wall_time)
                outcome.fmionnx_goal_distance = _goal_distance(
                    float(result["odometry.posX"][-1]), float(result["odometry.posY"][-1])
                )
            else:
                signals = hand.run(stop)
                outcome.handwritten.append(float(signals["wall_time"]))
                outcome.handwritten_goal_distance = _goal_distance(
                    float(signals["posX"][-1]), float(signals["posY"][-1])
                )
    return outcome


# -- timers ----------------------------------------------------------------------------------


@dataclass
class Breakdown:
    """Seconds per category over one loop, and the loop's wall time."""

    wall: float
    simulated: float
    seconds: dict[str, float]
    calls: dict[str, int]


def _timed(
    fn: Callable[..., None],
    category: str,
    seconds: dict[str, float],
    calls: dict[str, int],
    weight: int = 1,
) -> Callable[..., None]:
    """``fn`` timed into ``category``; one call counts as ``weight`` steps (native groups)."""
    clock = time.perf_counter

    def timed(*args: Any) -> None:
        started = clock()
        try:
            fn(*args)
        finally:
            seconds[category] += clock() - started
            calls[category] += weight

    return timed


def timed_breakdown(stop_time: float | None) -> Breakdown:
    """One run with every runner's ``step`` and ``produce`` wrapped in timers."""
    from fmionnx.core.types import Component
    from fmionnx.runtime.master import Master
    from fmionnx.runtime.result import RunOptions

    seconds: dict[str, float] = defaultdict(float)
    calls: dict[str, int] = defaultdict(int)

    class TimedMaster(Master):
        """Wraps each runner's methods before the master binds them into its schedule."""

        def _due(self, component: Component) -> Any:  # relies on Master's preparation order
            runner: Any = self.runners[component.name]
            step_category, produce_category = KIND_CATEGORIES.get(component.kind, (OTHER, OTHER))
            runner.step = _timed(runner.step, step_category, seconds, calls)
            runner.produce = _timed(runner.produce, produce_category, seconds, calls)
            return super()._due(component)

        def _entries(self, dues: Any) -> Any:
            """FMUs stepped by the native kernel bypass ``runner.step``: time their group."""
            from fmionnx.runtime.native.group import NativeGroup

            entries = super()._entries(dues)
            for due, _period in entries:
                group = getattr(due.step, "__self__", None)
                if isinstance(group, NativeGroup):
                    due.step = _timed(due.step, FMUS, seconds, calls, len(group.names))
            return entries

    compiled = load_system(stop_time).compiled
    result = TimedMaster(compiled, RunOptions()).run()
    measured = dict(seconds)
    measured[MASTER] = max(result.wall_time - sum(measured.values()), 0.0)
    return Breakdown(result.wall_time, result.simulated_time, measured, dict(calls))


# -- profile ---------------------------------------------------------------------------------

#: (substring of the file path or builtin's name, category), first match wins.
MODULE_RULES: tuple[tuple[str, str], ...] = (
    ("mjr_", RENDERING),
    ("mjv_", RENDERING),
    ("mujoco/renderer", RENDERING),
    ("mujoco/rendering", RENDERING),
    ("mujoco/egl", RENDERING),
    ("mujoco/osmesa", RENDERING),
    ("OpenGL", RENDERING),
    ("mujoco._functions.mj_", PHYSICS),
    ("kinds/mujoco/", PHYSICS),
    ("onnxruntime", INFERENCE),
    ("kinds/onnx/", INFERENCE),
    ("kinds/fmu/", FMUS),
    ("runtime/native", FMUS),
    ("fmpy", FMUS),
    ("runtime/master", MASTER),
    ("runtime/transfer", MASTER),
    ("runtime/recorder", MASTER),
    ("runtime/result", MASTER),
)


def categorize(filename: str, name: str) -> str | None:
    """Category of a profiled function from its file (or, for builtins, its name)."""
    where = filename.replace("\\", "/") + " " + name
    for needle, category in MODULE_RULES:
        if needle in where:
            return category
    return None


@dataclass
class Profile:
    """Self time per category (builtins charged to their callers) and the top functions."""

    wall: float
    seconds: dict[str, float]
    top: list[tuple[str, float]]


def _charge(stats: dict[Any, Any], key: Any, tt: float, depth: int = 0) -> dict[str, float]:
    """Split ``tt`` of an uncategorized function over its callers' categories."""
    filename, _, name = key
    category = categorize(filename, name)
    if category is not None:
        return {category: tt}
    callers = stats[key][4] if key in stats else {}
    total = sum(v[2] for v in callers.values()) if callers else 0.0
    if depth >= 4 or not callers or total <= 0:
        return {OTHER: tt}
    out: dict[str, float] = defaultdict(float)
    for caller, value in callers.items():
        for cat, share in _charge(stats, caller, tt * value[2] / total, depth + 1).items():
            out[cat] += share
    return out


def profile(stop_time: float | None, top: int = 12) -> Profile:
    """cProfile over the stepping loop only (preparation is not profiled)."""
    from fmionnx.runtime.master import Master
    from fmionnx.runtime.result import RunOptions

    profiler = cProfile.Profile()

    class ProfiledMaster(Master):
        """Profiles ``_loop`` (the stepping) and nothing else."""

        def _loop(self) -> None:
            profiler.enable()
            try:
                super()._loop()
            finally:
                profiler.disable()

    compiled = load_system(stop_time).compiled
    result = ProfiledMaster(compiled, RunOptions()).run()
    stats: dict[Any, Any] = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    seconds: dict[str, float] = defaultdict(float)
    for key, value in stats.items():
        for category, share in _charge(stats, key, value[2]).items():
            seconds[category] += share
    ranked = sorted(stats.items(), key=lambda item: item[1][2], reverse=True)[:top]
    functions = [(f"{Path(k[0]).name}:{k[1]}({k[2]})", v[2]) for k, v in ranked]
    return Profile(result.wall_time, dict(seconds), functions)


# -- the floor: the calls the scenario cannot avoid, timed one after the other ---------------

#: Camera and detector period, in base steps (10 Hz on the 2 ms grid).
FRAME_EVERY = 50


@dataclass
class Floor:
    """Seconds of the calls no implementation of the scenario can avoid, measured in sequence.

    Physics: every ``mj_step`` of the run, replaying the commands the fmionnx run applied;
    rendering: every camera frame (``update_scene`` + ``render`` into a reused buffer);
    measure: the colour-blob measure in plain numpy on every frame (what the detector
    computes; ``models/measure_detector.py``'s reference implementation).
    """

    steps: int
    frames: int
    physics: float
    rendering: float
    measure: float

    @property
    def total(self) -> float:
        """The sequential sum of the unavoidable calls."""
        return self.physics + self.rendering + self.measure


def _numpy_blobs() -> Callable[[Any], Any]:
    """The plain numpy colour-blob measure (loaded by path: ``models/`` is not a package)."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location(
        "measure_detector", REPO / "models" / "measure_detector.py"
    )
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, module)  # dataclasses look their module up there
    spec.loader.exec_module(module)
    measure: Callable[[Any], Any] = module.numpy_blobs
    return measure


def floor(v: Any, w: Any) -> Floor:
    """Replay the run's commands (``tracker.v``/``tracker.w`` per base step) through the calls.

    Same scene, timestep, camera and frame size as the system; a frame every
    :data:`FRAME_EVERY` base steps, of the state after that step's physics, as the master
    renders it.
    """
    import mujoco
    import numpy as np

    from benchmarks import handwritten_sign_follower as hand

    measure = _numpy_blobs()
    model = mujoco.MjModel.from_xml_path(str(hand.SCENE))
    model.opt.timestep = hand.PHYSICS_STEP
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, hand.HEIGHT, hand.WIDTH)
    frame = np.zeros((hand.HEIGHT, hand.WIDTH, 3), dtype=np.uint8)
    cmd_v, cmd_w = model.actuator("cmd_v").id, model.actuator("cmd_w").id
    mujoco.mj_forward(model, data)
    clock = time.perf_counter
    physics = rendering = measuring = 0.0
    steps = len(v) - 1
    frames = 0
    try:
        for n in range(steps):
            data.ctrl[cmd_v], data.ctrl[cmd_w] = v[n], w[n]
            began = clock()
            mujoco.mj_step(model, data)
            physics += clock() - began
            if n % FRAME_EVERY == 0:
                began = clock()
                renderer.update_scene(data, camera="front")
                renderer.render(out=frame)
                rendered = clock()
                measure(frame)
                measured = clock()
                rendering += rendered - began
                measuring += measured - rendered
                frames += 1
    finally:
        renderer.close()
    return Floor(steps, frames, physics, rendering, measuring)


# -- the master's schedules side by side -----------------------------------------------------

#: (label, schedule, FMUs isolated): ``fmionnx run``'s default isolates every FMU.
CONFIGURATIONS = (
    ("in-process FMUs, parallel", "parallel", False),
    ("in-process FMUs, sequential", "sequential", False),
    ("isolated FMUs, parallel", "parallel", True),
    ("isolated FMUs, sequential", "sequential", True),
)


@dataclass
class Schedules:
    """Loop wall times per configuration (interleaved), the floor, and identical results."""

    simulated: float
    walls: dict[str, list[float]] = field(default_factory=dict)
    concurrent: dict[str, int] = field(default_factory=dict)
    identical: bool = True
    floor: Floor | None = None
    floors: list[Floor] = field(default_factory=list)


def schedules(stop_time: float | None, repeats: int) -> Schedules:
    """Every configuration of :data:`CONFIGURATIONS` and the floor, interleaved per round.

    Round *r* starts with the *r*-th configuration; the floor is measured once per round,
    after the runs, replaying the commands of the first run. Results of every run are compared
    with the first one's, column by column, byte for byte.
    """
    from fmionnx.runtime.result import RunOptions, RunStatus

    system = load_system(stop_time)
    fmus = frozenset(c.name for c in system.compiled.components if c.kind == "fmu")
    outcome = Schedules(float(system.compiled.run.stop))
    reference: dict[str, Any] | None = None
    commands: tuple[Any, Any] | None = None
    for round_ in range(repeats):
        shift = round_ % len(CONFIGURATIONS)
        for label, schedule, isolated in CONFIGURATIONS[shift:] + CONFIGURATIONS[:shift]:
            options = RunOptions(schedule=schedule, isolate=fmus if isolated else frozenset())  # type: ignore[arg-type]
            result = system.run(options=options)
            if result.status is not RunStatus.COMPLETED:
                msg = f"sign_follower ({label}) ended {result.status}: {result.error}"
                raise RuntimeError(msg)
            outcome.walls.setdefault(label, []).append(result.wall_time)
            outcome.concurrent[label] = int(result.details.get("concurrent_steps") or 0)
            signals = {k: v.tobytes() for k, v in result.signals.items()}
            if reference is None:
                reference = signals
                commands = (result["tracker.v"], result["tracker.w"])
            elif signals != reference:
                outcome.identical = False
        assert commands is not None
        outcome.floors.append(floor(*commands))
    outcome.floor = min(outcome.floors, key=lambda f: f.total)
    return outcome


SCHEDULE_COLUMNS = (
    ("configuration", "master"),
    ("median_wall_s", "loop s (median)"),
    ("min_wall_s", "loop s (min)"),
    ("real_time_factor", "real-time factor"),
    ("vs_floor", "x floor"),
    ("vs_sequential", "x sequential"),
    ("concurrent_steps", "steps on a worker"),
)
FLOOR_COLUMNS = (
    ("call", "unavoidable call"),
    ("calls", "calls"),
    ("seconds", "s"),
    ("share", "share"),
)


def schedule_rows(outcome: Schedules) -> list[dict[str, Any]]:
    """One row per configuration: medians, real-time factor, ratio to the floor's sum."""
    floor_total = outcome.floor.total if outcome.floor else float("nan")
    medians = {label: statistics.median(w) for label, w in outcome.walls.items()}
    rows = []
    for label, schedule, isolated in CONFIGURATIONS:
        if label not in medians:
            continue
        twin = next(other for other, s, i in CONFIGURATIONS if i == isolated and s == "sequential")
        rows.append(
            {
                "configuration": label,
                "median_wall_s": medians[label],
                "min_wall_s": min(outcome.walls[label]),
                "walls_s": outcome.walls[label],
                "real_time_factor": outcome.simulated / medians[label],
                "vs_floor": medians[label] / floor_total,
                "vs_sequential": medians[label] / medians[twin] if twin in medians else None,
                "concurrent_steps": outcome.concurrent.get(label),
                "schedule": schedule,
                "isolated": isolated,
            }
        )
    return rows


def floor_rows(outcome: Schedules) -> list[dict[str, Any]]:
    """The floor's calls (the round with the smallest sum)."""
    f = outcome.floor
    if f is None:
        return []
    parts = (
        ("physics: mj_step", f.steps, f.physics),
        ("rendering: 640x480 frame", f.frames, f.rendering),
        ("colour-blob measure in numpy", f.frames, f.measure),
    )
    rows: list[dict[str, Any]] = [
        {"call": name, "calls": calls, "seconds": s, "share": s / f.total if f.total else None}
        for name, calls, s in parts
    ]
    rows.append({"call": "sum", "calls": None, "seconds": f.total, "share": 1.0})
    return rows


def schedule_targets(outcome: Schedules) -> list[dict[str, Any]]:
    """Issue 14's scenario targets, for the in-process parallel schedule, and issue 32's for
    the CLI's defaults (FMUs isolated, parallel)."""
    rows = {row["configuration"]: row for row in schedule_rows(outcome)}
    best = rows.get(CONFIGURATIONS[0][0])
    if best is None:
        return []
    default = rows[CONFIGURATIONS[2][0]]
    return [
        {"target": "scenario loop / sequential sum of unavoidable calls",
         "value": best["vs_floor"], "limit": "<= 0.8", "met": best["vs_floor"] <= 0.8},
        {"target": "the same with the CLI's defaults (FMUs isolated; issue 32)",
         "value": default["vs_floor"], "limit": "<= 0.8", "met": default["vs_floor"] <= 0.8},
        {"target": "scenario real-time factor on 2 cores", "value": best["real_time_factor"],
         "limit": ">= 6", "met": best["real_time_factor"] >= 6.0},
        {"target": "parallel and sequential schedules give identical results",
         "value": None, "limit": "identical", "met": outcome.identical},
    ]  # fmt: skip


# -- does a library release the GIL? ---------------------------------------------------------


def _stamper(stop: Any, stamps: list[float]) -> None:
    """Note the time every 0.1 ms or so, in Python: only while this thread holds the GIL."""
    clock = time.perf_counter
    last = clock()
    while not stop.is_set():
        now = clock()
        if now - last >= 1e-4:
            stamps.append(now)
            last = now


#: Each call's interval is cut into this many bins; the share with a stamp is its coverage.
BINS = 10


def _coverage(call: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """(seconds per call, share of each call's duration in which another thread ran Python).

    The call runs on this thread (a GL context is current here only); another thread notes
    the time in a Python loop. A call that holds the GIL leaves a gap in the notes over its
    whole duration (coverage near 0, the first or last bin at most); a call that releases it
    leaves none, except where the operating system gave the other thread no core (on a loaded
    machine the coverage is then below 1, but a gap over every call is the GIL's signature).
    The switch interval is made short so that the other thread gets the GIL back quickly.
    """
    import sys
    import threading

    stop, stamps = threading.Event(), []
    thread = threading.Thread(target=_stamper, args=(stop, stamps), daemon=True)
    interval = sys.getswitchinterval()
    windows = []
    thread.start()
    try:
        sys.setswitchinterval(1e-4)
        time.sleep(0.01)
        for _ in range(repeats):
            began = time.perf_counter()
            call()
            windows.append((began, time.perf_counter()))
            time.sleep(0.002)  # let the other thread note the time between calls
    finally:
        sys.setswitchinterval(interval)
        stop.set()
        thread.join()
    import bisect

    covered = 0
    for began, ended in windows:
        width = (ended - began) / BINS
        for b in range(BINS):
            low = began + b * width
            i = bisect.bisect_left(stamps, low)
            covered += i < len(stamps) and stamps[i] < low + width
    seconds = sum(e - b for b, e in windows) / len(windows)
    return seconds, covered / (BINS * len(windows))


def gil_probe(quick: bool = False) -> list[dict[str, Any]]:
    """Whether the scenario's heavy calls let another Python thread run while they work.

    Coverage (:func:`_coverage`): the share of each call's duration in which another thread
    ran Python code. ``time.sleep`` (releases the GIL) and ``sum(range(...))`` (holds it) are
    the references; a call counts as releasing the GIL when its coverage is above the
    midpoint between the two.
    """
    import mujoco
    import numpy as np
    import onnxruntime as ort

    from benchmarks import handwritten_sign_follower as hand

    model = mujoco.MjModel.from_xml_path(str(hand.SCENE))
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, hand.HEIGHT, hand.WIDTH)
    frame = np.zeros((hand.HEIGHT, hand.WIDTH, 3), dtype=np.uint8)
    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(
        str(MODELS / "sign_detector.onnx"), options, providers=["CPUExecutionProvider"]
    )
    renderer.update_scene(data, camera="front")
    context, scene, rect = renderer._mjr_context, renderer._scene, renderer._rect
    feeds = {session.get_inputs()[0].name: frame[np.newaxis]}
    k = 3 if quick else 20
    calls: list[tuple[str, Callable[[], Any], int]] = [
        ("time.sleep(2 ms) (reference: releases)", lambda: time.sleep(0.002), k),
        ("sum(range(300000)) (control: holds)", lambda: sum(range(300_000)), k),
        ("mujoco.mj_step x50", lambda: [mujoco.mj_step(model, data) for _ in range(50)], k),
        ("mujoco.mjr_render", lambda: mujoco.mjr_render(rect, scene, context), k),
        ("mujoco.mjr_readPixels", lambda: mujoco.mjr_readPixels(frame, None, rect, context), k),
        ("Renderer.render (both)", lambda: renderer.render(out=frame), k),
        ("onnxruntime run (detector)", lambda: session.run(None, feeds), k),
    ]
    try:
        rows = []
        for name, call, repeats in calls:
            seconds, coverage = _coverage(call, repeats)
            rows.append({"call": name, "ms_per_call": seconds * 1e3, "other_thread": coverage})
    finally:
        renderer.close()
    midpoint = (rows[0]["other_thread"] + rows[1]["other_thread"]) / 2
    for row in rows[2:]:
        row["releases_gil"] = row["other_thread"] > midpoint
    return rows


GIL_COLUMNS = (
    ("call", "call"),
    ("ms_per_call", "ms per call"),
    ("other_thread", "other thread ran (share of the call)"),
    ("releases_gil", "releases the GIL"),
)


def main(argv: list[str] | None = None) -> int:
    """``python benchmarks/scenario.py [--stop S] [--repeat R] [--quick]``: the schedules side by
    side with the floor, and the GIL probe (the rest runs from ``benchmarks/run.py``)."""
    import argparse
    import os
    import sys

    os.environ.setdefault("MUJOCO_GL", "egl")
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))
    from rich.console import Console

    from benchmarks import report

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--stop", type=float, default=None)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    if args.quick:
        args.stop, args.repeat = 0.2, 1
    console = Console(width=None if sys.stdout.isatty() else 150)
    print_schedules(console, schedules(args.stop, args.repeat), args.repeat, report)
    report.print_table(
        console, "Does the call release the GIL?", GIL_COLUMNS, gil_probe(args.quick)
    )
    return 0


def print_schedules(console: Any, outcome: Schedules, repeats: int, report: Any) -> None:
    """The three tables of the schedules' comparison."""
    report.print_table(
        console,
        f"Reference scenario, master schedules: {outcome.simulated:g} s simulated, median of "
        f"{repeats} interleaved; x floor = loop / sequential sum of the unavoidable calls; "
        f"results identical: {'yes' if outcome.identical else 'NO'}",
        SCHEDULE_COLUMNS,
        schedule_rows(outcome),
    )
    report.print_table(
        console, "The floor: unavoidable calls one after the other", FLOOR_COLUMNS,
        floor_rows(outcome),
    )  # fmt: skip
    report.print_table(console, "Scenario targets (issues 14 and 32)", report.TARGET_COLUMNS,
                       schedule_targets(outcome))  # fmt: skip


if __name__ == "__main__":
    import sys

    sys.exit(main())
