"""What ``fmionnx sweep`` costs and gains: cases per second on 1 and 2 Dask workers, against the
same cases run one after the other in a plain loop in this process.

Two studies, each run three ways side by side in one run (so machine load hits all alike):

1. **Small FMU system**: a ``signal`` into one ``Gain`` FMU, 100 base steps, 200 cases
   (``gain.k`` over a grid), nothing isolated: almost all of a case is the sweep's own
   machinery (task, transfer, record), the worst case for overhead per case.
2. **Reference scenario** ``systems/sign_follower.yaml``: 20 cases over the tracker's turn
   rate, the whole 32 s run by default (``--stop 4`` for a shorter one), FMUs
   isolated as ``fmionnx run`` does by default.

*loop* is :func:`fmionnx.backends.sweep.case.run_case` (what a worker runs for a case) called
for every case in this process: no Dask. *1 worker* / *2 workers* are a local Dask cluster of
that many processes, started for each round of its mode and closed after it, so that only the
cluster under test is alive while it is timed (an idle second cluster's scheduler and workers
take CPU from a busy one on two cores); the cluster's start and a warm-up (models shipped,
caches filled: a case per worker, for the small study a batched study of 8 cases) are timed
apart from the study (the mean per round). The modes are interleaved: every round runs in the
three modes, each round starting with another one, so that drifting machine load hits all
alike; a round of the small study is the whole 200-case study (repeated ``--rounds`` times),
a round of the reference scenario a slice of its cases (2 rounds by default: 10 of the 20
cases each, an even number, since an odd slice leaves one worker idle for a whole case at its
end and caps 2 workers at 1.67x for 5 cases a round). Every mode must give the same metrics
per case. The table shows how the engine cut the cases into Dask tasks (adaptive batches by
default, ``--batch N`` to fix the size, ``--batch 1`` for one case per task) and the
*time in cases*: the cases' wall times summed, over the mode's seconds times its workers --
near 100 % when the workers spend their time in cases rather than waiting for tasks (a
shortfall of speed-up then comes from the cores being shared, not from the sweep). Targets
(reported, never asserted): 2 workers >= 1.8x the cases/s of 1 worker; the sweep's overhead
(1 worker against the loop) <= 10 % of the loop on the reference scenario.

Run: ``python benchmarks/sweep.py`` (a few minutes on 2 cores), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

os.environ.setdefault("MUJOCO_GL", "egl")  # as the other benchmarks do; set before mujoco loads

from rich.console import Console  # noqa: E402

from benchmarks import chain, machine, report  # noqa: E402

LOOP = "loop"
MODES = (LOOP, "1 worker", "2 workers")
#: Worker processes of each mode (the loop is this one process).
WORKERS = dict(zip(MODES, (1, 1, 2), strict=True))
SPEEDUP_TARGET = 1.8
#: Cases of the warm-up study run on each new cluster before the small study is timed (the
#: reference scenario's warm-up is one case per worker: its cases take seconds).
WARM_UP = 8
OVERHEAD_TARGET = 0.10

SMALL_SYSTEM = """\
fmionnx: 1
name: small
run: {{stop: 1, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{y: {{sine: {{frequency: 1}}}}}}}}
  gain: {{kind: fmu, path: {gain}, parameters: {{v: [0, 0, 0]}}}}
connections:
  - src.y -> gain.u
"""
SMALL_STUDY = """\
fmionnx: 1
system: small.yaml
isolate: [none]
parameters:
  gain.k: {{range: {{start: 0.1, stop: 2, num: {cases}}}}}
metrics:
  peak: max(gain.y)
"""
SCENARIO_STUDY = """\
fmionnx: 1
system: {system}
parameters:
  tracker.turnRate: {{range: {{start: 0.6, stop: 1.2, num: {cases}}}}}
  run.stop: [{stop}]
metrics:
  x_end: final(odometry.posX)
  y_end: final(odometry.posY)
"""


@dataclass(frozen=True)
class Timing:
    """One mode of one study: the cases' wall time, the cluster's start, the metrics."""

    mode: str
    seconds: float
    startup: float
    metrics: dict[str, dict[str, float | None]]
    failed: int
    #: Cases run (a case repeated in several rounds counts each time).
    cases: int = 0
    #: Seconds spent inside the cases (each case's wall time, summed).
    inside: float = 0.0
    #: Cases per Dask task, every task of the study's rounds (empty for the loop).
    sizes: tuple[int, ...] = ()


def _plan(study: Path) -> Any:
    from fmionnx.results.sweep import plan_study

    return plan_study(study)[0]


def _job(plan: Any) -> Any:
    from fmionnx.backends.sweep.case import Job

    return Job.of(plan)


def _loop_cases(plan: Any, cases: Sequence[Any], shared: tuple[str, Any]) -> list[Any]:
    """Cases through ``run_case`` in this process, one after the other."""
    from fmionnx.backends.sweep.case import run_case

    text, packed = shared
    job = _job(plan)
    return [run_case(text, packed, case, job) for case in cases]


def _cluster_cases(
    client: Any, plan: Any, cases: Sequence[Any], batch: int | None, sizes: list[int]
) -> list[Any]:
    from fmionnx.backends.sweep.engine import run_study

    outcomes: list[Any] = []
    sizes.extend(run_study(client, plan, cases, _job(plan), outcomes.append, batch=batch).sizes)
    return outcomes


def measure(
    plan: Any,
    rounds: int,
    batch: int | None = None,
    *,
    whole: bool = False,
    warm_up: int | None = None,
) -> list[Timing]:
    """The three modes on the same cases, interleaved: the cases are cut into ``rounds``
    slices and each slice runs in every mode (starting with another mode each round), so
    drifting machine load hits all modes alike. The clusters start once, timed apart.

    ``whole``: every round runs the whole study instead of a slice (a short study repeated,
    so that each run is the study the issue names, not a quarter of it). ``warm_up``: cases
    run on each new cluster before it is timed (None: one per worker)."""
    from fmionnx.backends.sweep.engine import open_client
    from fmionnx.backends.sweep.models import pack_models
    from fmionnx.compile.systemfile import to_json

    shared = (to_json(plan.system), pack_models(plan.system))
    cases = list(plan.cases)
    slices = [cases] * rounds if whole else [cases[i::rounds] for i in range(rounds)]
    seconds = dict.fromkeys(MODES, 0.0)
    outcomes: dict[str, list[Any]] = {mode: [] for mode in MODES}
    startup: dict[str, float] = dict.fromkeys(MODES, 0.0)
    sizes: dict[str, list[int]] = {mode: [] for mode in MODES}
    _loop_cases(plan, cases[:1], shared)
    for index, part in enumerate(slices):
        order = MODES[index % 3 :] + MODES[: index % 3]
        for mode in order:
            if mode == LOOP:
                began = time.perf_counter()
                done = _loop_cases(plan, part, shared)
                seconds[mode] += time.perf_counter() - began
                outcomes[mode].extend(done)
                continue
            # Only the cluster under test is alive while it is timed: on two cores an idle
            # second cluster (a scheduler and its workers, ticking) takes from the busy one.
            workers = WORKERS[mode]
            began = time.perf_counter()
            with open_client(workers=workers) as client:
                client.wait_for_workers(workers)
                # Models shipped, caches filled (and for short cases, a batched study run once).
                count = workers if warm_up is None else warm_up
                warm = [dataclasses.replace(c, id=f"warm-up-{c.id}") for c in cases[:count]]
                _cluster_cases(client, plan, warm, batch, [])
                startup[mode] += (time.perf_counter() - began) / len(slices)
                began = time.perf_counter()
                done = _cluster_cases(client, plan, part, batch, sizes[mode])
                seconds[mode] += time.perf_counter() - began
            outcomes[mode].extend(done)
    return [
        Timing(
            mode,
            seconds[mode],
            startup[mode],
            {o.id: o.metrics for o in sorted(outcomes[mode], key=lambda o: o.id)},
            _failed(outcomes[mode]),
            len(outcomes[mode]),
            sum(o.wall_time for o in outcomes[mode]),
            tuple(sizes[mode]),
        )
        for mode in MODES
    ]


def _batches(sizes: Sequence[int]) -> str | None:
    """Cases per task: ``tasks, mean, largest`` (None for the loop)."""
    if not sizes:
        return None
    return f"{len(sizes)} tasks, mean {sum(sizes) / len(sizes):.1f}, max {max(sizes)}"


def _failed(outcomes: Sequence[Any]) -> int:
    return sum(o.status != "ok" for o in outcomes)


def rows(study: str, timings: list[Timing]) -> list[dict[str, Any]]:
    """One table row per mode; ratios against the loop and against 1 worker."""
    loop = timings[0]
    one = timings[1]
    cases = loop.cases
    out = []
    for timing in timings:
        same = timing.metrics == loop.metrics
        out.append(
            {
                "study": study,
                "mode": timing.mode,
                "cases": cases,
                "seconds": timing.seconds,
                "cases_per_s": cases / timing.seconds if timing.seconds else None,
                "startup": timing.startup if timing.mode != LOOP else None,
                "vs_1_worker": one.seconds / timing.seconds if timing.mode != LOOP else None,
                "overhead_per_case_ms": (timing.seconds - loop.seconds) / cases * 1000
                if timing.mode == "1 worker"
                else None,
                "overhead_share": (timing.seconds - loop.seconds) / loop.seconds
                if timing.mode == "1 worker"
                else None,
                "busy_share": timing.inside / (timing.seconds * WORKERS[timing.mode])
                if timing.seconds
                else None,
                "batch": _batches(timing.sizes),
                "failed": timing.failed,
                "same_metrics": same,
            }
        )
    return out


COLUMNS = (
    ("study", "study"),
    ("mode", "mode"),
    ("cases", "cases"),
    ("seconds", "s (cases only)"),
    ("cases_per_s", "cases/s"),
    ("startup", "cluster start + warm-up s"),
    ("vs_1_worker", "speed-up vs 1 worker"),
    ("overhead_per_case_ms", "overhead ms/case vs loop"),
    ("overhead_share", "overhead share"),
    ("busy_share", "time in cases"),
    ("batch", "cases per task"),
    ("failed", "failed"),
    ("same_metrics", "same metrics as loop"),
)


def targets(small: list[dict[str, Any]], scenario: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The issue's two targets, measured on the reference scenario (speed-up on both)."""
    found = []
    for study_rows in (small, scenario):
        if not study_rows:  # skipped
            continue
        two = next(r for r in study_rows if r["mode"] == "2 workers")
        found.append(
            {
                "target": f"2 workers vs 1 ({two['study']})",
                "value": two["vs_1_worker"],
                "limit": f">= {SPEEDUP_TARGET}",
                "met": two["vs_1_worker"] is not None and two["vs_1_worker"] >= SPEEDUP_TARGET,
            }
        )
    if not scenario:
        return found
    one = next(r for r in scenario if r["mode"] == "1 worker")
    found.append(
        {
            "target": "overhead vs plain loop (reference scenario)",
            "value": one["overhead_share"],
            "limit": f"<= {OVERHEAD_TARGET:.0%}",
            "met": one["overhead_share"] is not None and one["overhead_share"] <= OVERHEAD_TARGET,
        }
    )
    return found


def _study_rows(
    name: str, study: Path, args: argparse.Namespace, *, whole: bool = False
) -> list[dict[str, Any]]:
    warm_up = WARM_UP if whole else None
    return rows(name, measure(_plan(study), args.rounds, args.batch, whole=whole, warm_up=warm_up))


def main(argv: list[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Run both studies in the three modes, print the tables, return what was measured."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: 10 + 2 short cases")
    parser.add_argument("--small-cases", type=int, default=200)
    parser.add_argument("--scenario-cases", type=int, default=20)
    parser.add_argument("--stop", type=float, default=32.0, help="reference scenario stop time")
    parser.add_argument(
        "--rounds",
        type=int,
        default=2,
        help="interleaved rounds per study (keep the scenario's cases per round even)",
    )
    parser.add_argument(
        "--batch", type=int, default=None, help="cases per task (default: adaptive; 1: none)"
    )
    parser.add_argument("--skip-small", action="store_true", help="only the reference scenario")
    parser.add_argument("--skip-scenario", action="store_true", help="only the small study")
    args = parser.parse_args(argv)
    if args.quick:
        args.small_cases, args.scenario_cases, args.stop, args.rounds = 10, 2, 0.5, 2
    console = console or Console()
    with tempfile.TemporaryDirectory(prefix="fmionnx-bench-sweep-") as scratch:
        folder = Path(scratch)
        with chain.built_gain(folder) as (gain, _):
            (folder / "small.yaml").write_text(SMALL_SYSTEM.format(gain=gain), encoding="utf-8")
            small_study = folder / "small-study.yaml"
            small_study.write_text(SMALL_STUDY.format(cases=args.small_cases), encoding="utf-8")
            scenario_study = folder / "scenario-study.yaml"
            scenario_study.write_text(
                SCENARIO_STUDY.format(
                    system=REPO / "systems" / "sign_follower.yaml",
                    cases=args.scenario_cases,
                    stop=args.stop,
                ),
                encoding="utf-8",
            )
            load_before = os.getloadavg()
            small = (
                []
                if args.skip_small
                else _study_rows(
                    f"small FMU system ({args.small_cases} cases x {args.rounds})",
                    small_study,
                    args,
                    whole=True,
                )
            )
            scenario = (
                []
                if args.skip_scenario
                else _study_rows(f"reference ({args.stop:g} s)", scenario_study, args)
            )
    found = targets(small, scenario)
    report.print_table(
        console,
        "Sweep: cases per second, 1 and 2 workers, against a plain loop",
        COLUMNS,
        [*small, *scenario],
    )
    report.print_table(console, "Targets", report.TARGET_COLUMNS, found)
    console.print(
        f"machine: {machine.cpu_model()}, {machine.usable_cores()} usable cores "
        "(shared with other work: ratios measured side by side in one run); load average "
        f"before {load_before[0]:.2f}, after {os.getloadavg()[0]:.2f}"
    )
    return {"small": small, "scenario": scenario, "targets": found}


if __name__ == "__main__":
    main()
