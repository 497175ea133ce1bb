"""Turn measurements into rows (for the JSON file) and tables (for the terminal).

Rows are plain dicts of numbers and strings, so ``results.json`` and the printed tables are
built from the same values. Targets are *reported*, never asserted: a benchmark that fails a
target still prints every number.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from rich.console import Console
from rich.table import Table

from benchmarks.chain import CTYPES_FLOOR, FMIONNX, FMPY_LOOP, LIBCOSIM, SIMULATE_FMU, Outcome
from benchmarks.scenario import CATEGORIES, Breakdown, Profile, RealTime

Row = dict[str, Any]


def _ratio(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or b == 0 or math.isnan(a) or math.isnan(b):
        return None
    return a / b


def chain_rows(outcomes: Sequence[Outcome]) -> list[Row]:
    """One row per (N, contender): median/min µs per step, per FMU, ratios to floor and fmionnx."""
    medians = {(o.n, o.contender): o.median_us for o in outcomes if o.samples}
    rows = []
    for o in outcomes:
        median = medians.get((o.n, o.contender))
        rows.append(
            {
                "n": o.n,
                "contender": o.contender,
                "median_us_per_step": median,
                "min_us_per_step": o.min_us if o.samples else None,
                "us_per_fmu_step": median / o.n if median is not None else None,
                "vs_floor": _ratio(median, medians.get((o.n, CTYPES_FLOOR))),
                "vs_fmionnx": _ratio(median, medians.get((o.n, FMIONNX))),
                "repetitions": len(o.samples),
                "steps": o.samples[0].steps if o.samples else None,
                "correct": o.correct if o.samples else None,
                "skipped": o.skipped,
                "samples_us_per_step": [s.per_step * 1e6 for s in o.samples],
            }
        )
    return rows


def chain_targets(outcomes: Sequence[Outcome], target_n: int = 10) -> list[Row]:
    """The issue's targets on the chain (master per-step time), with whether each is met."""
    medians = {(o.n, o.contender): o.median_us for o in outcomes if o.samples}
    sizes = sorted({o.n for o in outcomes})
    n = target_n if target_n in sizes else (sizes[-1] if sizes else target_n)
    own = medians.get((n, FMIONNX))
    targets = []

    def add(name: str, value: float | None, limit: str, met: bool | None) -> None:
        targets.append({"target": name, "value": value, "limit": limit, "met": met})

    fmpy = _ratio(own, medians.get((n, FMPY_LOOP)))
    add(f"N={n}: fmionnx / fmpy loop", fmpy, "<= 1", None if fmpy is None else fmpy <= 1.0)
    floor = _ratio(own, medians.get((n, CTYPES_FLOOR)))
    add(f"N={n}: fmionnx / ctypes floor", floor, "<= 2", None if floor is None else floor <= 2.0)
    for size in sizes:
        simulate = _ratio(medians.get((size, FMIONNX)), medians.get((size, SIMULATE_FMU)))
        if simulate is not None:
            add(f"N={size}: fmionnx / fmpy.simulate_fmu", simulate, "< 1", simulate < 1.0)
    for size in sizes:
        cosim = _ratio(medians.get((size, FMIONNX)), medians.get((size, LIBCOSIM)))
        add(f"N={size}: fmionnx / libcosimpy", cosim, "< 1", None if cosim is None else cosim < 1.0)
    return targets


def scenario_rows(real: RealTime) -> list[Row]:
    """Real-time factors of both implementations of the reference scenario."""
    rows = []
    for name, walls, goal in (
        ("fmionnx (in-process master)", real.fmionnx, real.fmionnx_goal_distance),
        ("hand-written loop", real.handwritten, real.handwritten_goal_distance),
    ):
        rows.append(
            {
                "implementation": name,
                "simulated_s": real.simulated,
                "median_wall_s": sorted(walls)[len(walls) // 2] if walls else None,
                "walls_s": walls,
                "real_time_factor": RealTime.factor(walls, real.simulated),
                "goal_distance_m": goal,
            }
        )
    return rows


def breakdown_rows(timers: Breakdown | None, prof: Profile | None) -> list[Row]:
    """Share of the loop per category, from the timers and from the profile."""
    rows = []
    for category in CATEGORIES:
        row: Row = {"category": category}
        if timers is not None:
            seconds = timers.seconds.get(category, 0.0)
            row["timer_s"] = seconds
            row["timer_share"] = seconds / timers.wall if timers.wall else None
            row["timer_calls"] = timers.calls.get(category, 0)
        if prof is not None:
            total = sum(prof.seconds.values())
            seconds = prof.seconds.get(category, 0.0)
            row["profile_s"] = seconds
            row["profile_share"] = seconds / total if total else None
        rows.append(row)
    return rows


# -- printing ------------------------------------------------------------------------------------


def _cell(key: str, value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        if math.isnan(value):
            return "-"
        if key.endswith("share"):
            return f"{value:.1%}"
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def print_table(
    console: Console, title: str, columns: Sequence[tuple[str, str]], rows: Sequence[Row]
) -> None:
    """``columns``: (row key, header). Numbers right-aligned, missing values as ``-``."""
    table = Table(title=title, title_justify="left")
    for _, header in columns:
        table.add_column(header, justify="left" if header[:1].isalpha() else "right")
    for row in rows:
        table.add_row(*(_cell(key, row.get(key)) for key, _ in columns))
    console.print(table)


CHAIN_COLUMNS = (
    ("n", "N"),
    ("contender", "loop"),
    ("median_us_per_step", "µs/step (median)"),
    ("min_us_per_step", "µs/step (min)"),
    ("us_per_fmu_step", "µs per FMU-step"),
    ("vs_floor", "x floor"),
    ("vs_fmionnx", "x fmionnx"),
    ("correct", "tail = 2^N"),
    ("skipped", "not run because"),
)
TARGET_COLUMNS = (
    ("target", "target"),
    ("value", "measured ratio"),
    ("limit", "goal"),
    ("met", "met"),
)
SCENARIO_COLUMNS = (
    ("implementation", "implementation"),
    ("simulated_s", "simulated s"),
    ("median_wall_s", "wall s (median)"),
    ("real_time_factor", "real-time factor"),
    ("goal_distance_m", "end to B, m"),
)
BREAKDOWN_COLUMNS = (
    ("category", "category"),
    ("timer_s", "timers: s"),
    ("timer_share", "timers: share"),
    ("timer_calls", "calls"),
    ("profile_s", "cProfile: s"),
    ("profile_share", "cProfile: share"),
)
