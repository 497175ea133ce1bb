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
