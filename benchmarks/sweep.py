"""What ``fmionnx sweep`` costs and gains: cases per second on 1 and 2 Dask workers, against the
same cases run one after the other in a plain loop in this process, and in two plain processes
side by side (what this machine gives two processes at all).

Two studies, each run four ways side by side in one run (so machine load hits all alike):

1. **Small FMU system**: a ``signal`` into one ``Gain`` FMU, 100 base steps, 200 cases
   (``gain.k`` over a grid), nothing isolated: almost all of a case is the sweep's own
   machinery (task, transfer, record), the worst case for overhead per case.
2. **Reference scenario** ``systems/sign_follower.yaml``: 20 cases over the tracker's turn
   rate, the whole 32 s run by default (``--stop 4`` for a shorter one), FMUs
   isolated as ``fmionnx run`` does by default.

*loop* is :func:`fmionnx.backends.sweep.case.run_case` (what a worker runs for a case) called
for every case in this process: no Dask. *2 processes* is the same loop in two plain processes
(spawned once, each given half of a round's cases, both at once), timed right after or before
one of them runs all of the round's cases alone: no Dask either, and the ratio of the two is
the machine's own ceiling for 2 workers -- on a shared virtual machine two processes do not
always get two cores' worth. *1 worker* / *2 workers* are a local Dask cluster of
that many processes, started for each round of its mode and closed after it, so that only the
cluster under test is alive while it is timed (an idle second cluster's scheduler and workers
take CPU from a busy one on two cores); the cluster's start and a warm-up (models shipped,
caches filled: a case per worker, for the small study a batched study of 8 cases) are timed
apart from the study (the mean per round). The modes are interleaved: every round runs in the
four modes, each round starting with another one, so that drifting machine load hits all
alike; a round of the small study is the whole 200-case study (repeated ``--rounds`` times),
a round of the reference scenario a slice of its cases (5 rounds by default: 4 of the 20
cases each, an even number, since an odd slice leaves one worker idle for a whole case at its
end and caps 2 workers at 1.67x for 5 cases a round; with 2 rounds the loop's own time, 10
cases in one go, varied by about 10 % from run to run on a shared machine). Every mode must
give the same metrics per case. The table shows how the engine cut the cases into Dask tasks (adaptive batches by
default, ``--batch N`` to fix the size, ``--batch 1`` for one case per task) and the
*time in cases*: the cases' wall times summed, over the mode's seconds times its workers --
near 100 % when the workers spend their time in cases rather than waiting for tasks (a
shortfall of speed-up then comes from the cores being shared, not from the sweep). For the
small study each cluster also runs studies of one case per worker after its timed study: their
median time is the *latency* of a study (what it costs besides its cases: packing and sending
the tasks, the first case starting, the last result coming back). Targets (reported, never
asserted): 2 workers >= 1.8x the cases/s of 1 worker; the sweep's overhead (1 worker against
the loop) <= 10 % of the loop on the reference scenario. Reported beside them: the machine's
ceiling (2 plain processes against 1) and, for the small study, the ratio 2 workers would
reach if a study cost only its measured latency besides its cases, the cases running as fast
as in 1 plain process (1 worker) and as in 2 (2 workers).

Run: ``python benchmarks/sweep.py`` (a few minutes on 2 cores), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

os.environ.setdefault("MUJOCO_GL", "egl")  # as the other benchmarks do; set before mujoco loads

from rich.console import Console  # noqa: E402

from benchmarks import chain, machine, report  # noqa: E402

LOOP = "loop"
PROCESSES = "2 processes"
MODES = (LOOP, PROCESSES, "1 worker", "2 workers")
#: Processes running cases in each mode (the loop is this one process).
WORKERS = dict(zip(MODES, (1, 2, 1, 2), strict=True))
#: Studies of one case per worker run on each cluster after its timed study (small study only),
#: whose median time is the study's latency.
LATENCY_STUDIES = 5
#: Seconds the client is left idle before each timed study. `fmionnx sweep` submits a study on a
#: client that has sent nothing for a while; right after the warm-up study the first tasks
#: would wait out Dask's 10-ms batching of the client's messages (6-7 ms more per study).
IDLE_BEFORE_STUDY = 0.05
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
    #: Cases per Dask task, every task of the study's rounds (empty without Dask).
    sizes: tuple[int, ...] = ()
    #: Median seconds of a study of one case per worker on this mode's cluster (None: not
    #: measured, or no cluster).
    latency: float | None = None
    #: *2 processes* only: seconds of one of the processes running the same cases alone.
    alone: float = 0.0


def _plan(study: Path) -> Any:
    from fmionnx.pipeline.sweep import plan_study

    return plan_study(study)[0]


def _job(plan: Any) -> Any:
    from fmionnx.backends.sweep.case import Job

    return Job.of(plan)


def _loop_cases(plan: Any, cases: Sequence[Any], shared: tuple[str, Any]) -> list[Any]:
    """Cases through ``run_case`` in this process, one after the other."""
    from fmionnx.backends.sweep.case import run_case
    from fmionnx.pipeline.study import run_study_case

    text, packed = shared
    job = _job(plan)
    return [run_case(text, packed, case, job, run_study_case) for case in cases]


def _warm_loop(study: Path) -> tuple[Any, list[Any], tuple[str, Any]]:
    """The study's plan, cases and shared values (system JSON, packed models), its first case
    run once in this process: what the loop, in this process or another, starts from."""
    from fmionnx.backends.sweep.models import pack_models
    from fmionnx.compile.systemfile import to_json

    plan = _plan(study)
    shared = (to_json(plan.system), pack_models(plan.system))
    cases = list(plan.cases)
    _loop_cases(plan, cases[:1], shared)
    return plan, cases, shared


def _side(study: str, conn: Connection) -> None:
    """One process of the *2 processes* mode: runs the cases it is sent (their places in the
    study) as the loop does, until sent None."""
    plan, cases, shared = _warm_loop(Path(study))
    conn.send(None)
    while (places := conn.recv()) is not None:
        conn.send(_loop_cases(plan, [cases[i] for i in places], shared))


class _Pair:
    """Two plain processes side by side, started once for all rounds: between rounds they wait
    on their pipes and take no CPU from the other modes."""

    def __init__(self, study: Path) -> None:
        context = multiprocessing.get_context("spawn")  # as Dask starts its workers
        self._pipes: list[Connection] = []
        self._processes: list[Any] = []
        for _ in range(2):
            ours, theirs = context.Pipe()
            process = context.Process(target=_side, args=(str(study), theirs), daemon=True)
            process.start()
            theirs.close()
            self._pipes.append(ours)
            self._processes.append(process)
        for pipe in self._pipes:
            pipe.recv()

    def run(self, places: Sequence[int]) -> list[Any]:
        """The cases at ``places``, the first half in one process and the rest in the other."""
        half = (len(places) + 1) // 2
        for pipe, part in zip(self._pipes, (places[:half], places[half:]), strict=True):
            pipe.send(list(part))
        return [outcome for pipe in self._pipes for outcome in pipe.recv()]

    def run_alone(self, places: Sequence[int], which: int) -> list[Any]:
        """The cases at ``places`` in process ``which`` (0 or 1), the other one idle."""
        self._pipes[which].send(list(places))
        outcomes: list[Any] = self._pipes[which].recv()
        return outcomes

    def close(self) -> None:
        for pipe in self._pipes:
            # A process already gone: the error that ended the rounds is the one to see.
            with contextlib.suppress(OSError):
                pipe.send(None)
        for process in self._processes:
            process.join(timeout=30)
            if process.is_alive():
                process.kill()


def _cluster_cases(
    client: Any, plan: Any, cases: Sequence[Any], batch: int | None, sizes: list[int]
) -> list[Any]:
    from fmionnx.backends.sweep.engine import run_study
    from fmionnx.pipeline.study import run_study_case

    outcomes: list[Any] = []
    sizes.extend(
        run_study(
            client, plan, cases, _job(plan), outcomes.append, run_study_case, batch=batch
        ).sizes
    )
    return outcomes


def measure(
    study: Path,
    rounds: int,
    batch: int | None = None,
    *,
    whole: bool = False,
    warm_up: int | None = None,
) -> list[Timing]:
    """The four modes on the same cases, interleaved: the cases are cut into ``rounds``
    slices and each slice runs in every mode (starting with another mode each round), so
    drifting machine load hits all modes alike. Each round's clusters start apart from the
    timing.

    ``whole``: every round runs the whole study instead of a slice (a short study repeated,
    so that each run is the study the issue names, not a quarter of it), and each cluster's
    latency is measured. ``warm_up``: cases run on each new cluster before it is timed (None:
    one per worker)."""
    from fmionnx.backends.sweep.engine import open_client

    plan, cases, shared = _warm_loop(study)
    places = list(range(len(cases)))
    slices = [places] * rounds if whole else [places[i::rounds] for i in range(rounds)]
    seconds = dict.fromkeys(MODES, 0.0)
    outcomes: dict[str, list[Any]] = {mode: [] for mode in MODES}
    startup: dict[str, float] = dict.fromkeys(MODES, 0.0)
    sizes: dict[str, list[int]] = {mode: [] for mode in MODES}
    latencies: dict[str, list[float]] = {mode: [] for mode in MODES}
    alone = 0.0
    pair = _Pair(study)
    try:
        for index, part_places in enumerate(slices):
            part = [cases[i] for i in part_places]
            order = MODES[index % len(MODES) :] + MODES[: index % len(MODES)]
            for mode in order:
                if mode == LOOP:
                    began = time.perf_counter()
                    outcomes[mode].extend(_loop_cases(plan, part, shared))
                    seconds[mode] += time.perf_counter() - began
                    continue
                if mode == PROCESSES:
                    # One process alone and both side by side, one right after the other (in
                    # turn the first), so that the ratio of the two sees the same machine.
                    for side_by_side in (index % 2 == 0, index % 2 == 1):
                        began = time.perf_counter()
                        if side_by_side:
                            outcomes[mode].extend(pair.run(part_places))
                            seconds[mode] += time.perf_counter() - began
                        else:
                            pair.run_alone(part_places, index % 2)
                            alone += time.perf_counter() - began
                    continue
                # Only the cluster under test is alive while it is timed: on two cores an idle
                # second cluster (a scheduler and its workers, ticking) takes from the busy one.
                workers = WORKERS[mode]
                began = time.perf_counter()
                with open_client(workers=workers) as client:
                    client.wait_for_workers(workers)
                    # Models shipped, caches filled (and for short cases, a batched study run
                    # once).
                    count = workers if warm_up is None else warm_up
                    warm = [dataclasses.replace(c, id=f"warm-up-{c.id}") for c in cases[:count]]
                    _cluster_cases(client, plan, warm, batch, [])
                    startup[mode] += (time.perf_counter() - began) / len(slices)
                    time.sleep(IDLE_BEFORE_STUDY)
                    began = time.perf_counter()
                    done = _cluster_cases(client, plan, part, batch, sizes[mode])
                    seconds[mode] += time.perf_counter() - began
                    if whole:
                        for _ in range(LATENCY_STUDIES):
                            time.sleep(IDLE_BEFORE_STUDY)
                            began = time.perf_counter()
                            _cluster_cases(client, plan, cases[:workers], batch, [])
                            latencies[mode].append(time.perf_counter() - began)
                outcomes[mode].extend(done)
    finally:
        pair.close()
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
            statistics.median(latencies[mode]) if latencies[mode] else None,
            alone if mode == PROCESSES else 0.0,
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


def rows(study: str, timings: list[Timing], rounds: int) -> list[dict[str, Any]]:
    """One table row per mode: ratios against the loop, 1 worker and 1 plain process; for the
    2 workers, the ratio its latency allows (``latency_bound``, when measured)."""
    by_mode = {timing.mode: timing for timing in timings}
    loop, one, two = by_mode[LOOP], by_mode["1 worker"], by_mode["2 workers"]
    cases = loop.cases
    out = []
    for timing in timings:
        clustered = timing.mode in ("1 worker", "2 workers")
        out.append(
            {
                "study": study,
                "mode": timing.mode,
                "cases": cases,
                "seconds": timing.seconds,
                "cases_per_s": cases / timing.seconds if timing.seconds else None,
                "startup": timing.startup if clustered else None,
                "vs_1_worker": one.seconds / timing.seconds if clustered else None,
                "vs_1_process": timing.alone / timing.seconds if timing.mode == PROCESSES else None,
                "overhead_per_case_ms": (timing.seconds - loop.seconds) / cases * 1000
                if timing.mode == "1 worker"
                else None,
                "overhead_share": (timing.seconds - loop.seconds) / loop.seconds
                if timing.mode == "1 worker"
                else None,
                "busy_share": timing.inside / (timing.seconds * WORKERS[timing.mode])
                if timing.seconds
                else None,
                "latency_ms": timing.latency * 1000 if timing.latency is not None else None,
                "batch": _batches(timing.sizes),
                "failed": timing.failed,
                "same_metrics": timing.metrics == loop.metrics,
            }
        )
    processes = by_mode[PROCESSES]
    if one.latency is not None and two.latency is not None:
        # A study costing only its latency besides its cases: on 1 worker the cases as fast
        # as in 1 plain process, on 2 as fast as in 2 (per round: one study).
        alone = one.latency + processes.alone / rounds
        paired = two.latency + processes.seconds / rounds
        out[MODES.index("2 workers")]["latency_bound"] = alone / paired
    return out


COLUMNS = (
    ("study", "study"),
    ("mode", "mode"),
    ("cases", "cases"),
    ("seconds", "s (cases only)"),
    ("cases_per_s", "cases/s"),
    ("startup", "cluster start + warm-up s"),
    ("vs_1_worker", "speed-up vs 1 worker"),
    ("vs_1_process", "vs 1 process"),
    ("overhead_per_case_ms", "overhead ms/case vs loop"),
    ("overhead_share", "overhead share"),
    ("busy_share", "time in cases"),
    ("latency_ms", "latency ms"),
    ("batch", "cases per task"),
    ("failed", "failed"),
    ("same_metrics", "same metrics as loop"),
)


def targets(small: list[dict[str, Any]], scenario: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The issue's two targets, measured on the reference scenario (speed-up on both), and
    beside each speed-up what bounds it: the machine's ceiling (2 plain processes against 1)
    and, where measured, the ratio a study costing only its latency would reach."""
    found = []
    for study_rows in (small, scenario):
        if not study_rows:  # skipped
            continue
        two = next(r for r in study_rows if r["mode"] == "2 workers")
        processes = next(r for r in study_rows if r["mode"] == PROCESSES)
        found.append(
            {
                "target": f"2 workers vs 1 ({two['study']})",
                "value": two["vs_1_worker"],
                "limit": f">= {SPEEDUP_TARGET}",
                "met": two["vs_1_worker"] is not None and two["vs_1_worker"] >= SPEEDUP_TARGET,
            }
        )
        found.append(
            {
                "target": f"  this machine: 2 plain processes vs 1, no Dask ({two['study']})",
                "value": processes["vs_1_process"],
                "limit": None,
                "met": None,
            }
        )
        if two.get("latency_bound") is not None:
            found.append(
                {
                    "target": "  2 workers vs 1 from 1 and 2 processes' times plus the latency",
                    "value": two["latency_bound"],
                    "limit": None,
                    "met": None,
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
    timings = measure(study, args.rounds, args.batch, whole=whole, warm_up=warm_up)
    return rows(name, timings, args.rounds)


def scaling(args: argparse.Namespace, console: Console) -> dict[str, Any]:
    """The scaling tables (:mod:`benchmarks.sweep_scaling`): ``fmionnx sweep`` as a user runs it
    on 1, 2, 4, ... workers up to this machine's cores."""
    from benchmarks import sweep_scaling as scale

    cores = args.max_workers or machine.usable_cores()
    counts = scale.worker_counts(cores)
    cases = args.scaling_cases or max(scale.REFERENCE_CASES, scale.CASES_PER_WORKER * counts[-1])
    pair = min(2, counts[-1])
    with tempfile.TemporaryDirectory(prefix="fmionnx-bench-scaling-") as scratch:
        folder = Path(scratch)
        env = scale.scaling_env(folder / "cache")
        reference = scale.Study(
            "reference",
            scale.reference_study(folder, "reference", cases, args.scaling_stop, isolated=True),
            cases,
        )
        plain = scale.Study(
            "reference, isolate: [none]",
            scale.reference_study(folder, "plain", cases, args.scaling_stop, isolated=False),
            cases,
        )
        spawned = scale.Study(
            "reference, workers spawned",
            reference.path,
            cases,
            environ={"FMIONNX_FORK_WORKERS": "0"},
        )
        with chain.built_gain(folder) as (gain, _):
            (folder / "small.yaml").write_text(SMALL_SYSTEM.format(gain=gain), encoding="utf-8")
            small_path = folder / "small-study.yaml"
            small_path.write_text(SMALL_STUDY.format(cases=args.small_cases), encoding="utf-8")
            small = scale.Study("small FMU system", small_path, args.small_cases)
            # Untimed: bytecode, the compile cache, the page cache (one short study each way).
            for study in (small, reference):
                scale.sweep_once(study, 1, folder / "warm-up", env)
                study.walls.clear()
                study.case_walls.clear()
                study.failed = 0
            runs = [(reference, w) for w in counts] + [(plain, pair), (spawned, pair)]
            runs += [(small, w) for w in counts]
            load_before = os.getloadavg()
            scale.measure(runs, args.scaling_rounds, folder, env)
    found_rows = [*scale.rows(reference), *scale.rows(plain), *scale.rows(spawned)]
    found_rows += scale.rows(small)
    ratio = scale.isolation_ratio(reference, plain, pair)
    found_targets = scale.targets(scale.rows(reference), ratio, cores)
    report.print_table(
        console,
        f"Sweep scaling: `fmionnx sweep --workers W`, whole command, reference {cases} cases of "
        f"{args.scaling_stop:g} s (FMUs isolated, one thread per worker), median of "
        f"{args.scaling_rounds} interleaved rounds",
        scale.COLUMNS,
        found_rows,
    )
    report.print_table(console, "Scaling targets", report.TARGET_COLUMNS, found_targets)
    console.print(
        f"machine: {machine.cpu_model()}, {machine.usable_cores()} usable cores, workers up to "
        f"{cores}; load average before {load_before[0]:.2f}, after {os.getloadavg()[0]:.2f}"
    )
    failed = reference.failed + plain.failed + spawned.failed + small.failed
    return {"rows": found_rows, "targets": found_targets, "failed": failed, "counts": counts}


def main(argv: list[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """The scaling tables; with ``--modes`` both studies in the four modes too. Prints the
    tables, returns what was measured."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: 10 + 2 short cases")
    parser.add_argument(
        "--modes",
        action="store_true",
        help="also the loop, 2 plain processes, 1 and 2 workers on the same cases",
    )
    parser.add_argument("--skip-scaling", action="store_true", help="no scaling tables")
    parser.add_argument("--scaling-rounds", type=int, default=2)
    parser.add_argument("--scaling-stop", type=float, default=8.0, help="reference stop time")
    parser.add_argument("--scaling-cases", type=int, default=None, help="reference cases")
    parser.add_argument("--max-workers", type=int, default=None, help="default: usable cores")
    parser.add_argument("--small-cases", type=int, default=200)
    parser.add_argument("--scenario-cases", type=int, default=20)
    parser.add_argument("--stop", type=float, default=32.0, help="reference scenario stop time")
    parser.add_argument(
        "--rounds",
        type=int,
        default=5,
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
        args.scaling_rounds, args.scaling_stop = 1, 0.2
        args.scaling_cases = args.scaling_cases or 4
        args.max_workers = args.max_workers or 2
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    found: dict[str, Any] = {}
    if not args.skip_scaling:
        found["scaling"] = scaling(args, console)
    if not args.modes:
        return found
    found.update(modes(args, console))
    return found


def modes(args: argparse.Namespace, console: Console) -> dict[str, Any]:
    """Both studies in the four modes (loop, 2 plain processes, 1 and 2 workers)."""
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
