"""``make bench``: every benchmark, its tables on the terminal and ``build/bench/results.json``.

1. master overhead (:mod:`benchmarks.chain`): a chain of N Gain FMUs, five loops side by side;
2. the reference scenario (:mod:`benchmarks.scenario`): real-time factor against the
   hand-written loop, and where the time goes;
3. the other benchmark scripts in this folder (``validate_large.py``, ``ros2_*.py``,
   ``isolation.py``), each run as its own process with its output kept.

Targets are reported, not asserted. The whole run takes a few minutes on 2 cores; ``--quick``
runs every part on a tiny size (what the smoke test does).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

os.environ.setdefault("MUJOCO_GL", "egl")  # as the hand-written loop does; set before mujoco loads

from rich.console import Console  # noqa: E402

from benchmarks import chain, machine, report, scenario  # noqa: E402

DEFAULT_OUT = REPO / "build" / "bench" / "results.json"
#: Scripts owned by others that ``make bench`` runs as they are, when present.
EXTERNAL_PATTERNS = (
    "validate_large.py",
    "ros2_*.py",
    "isolation.py",
    "detector.py",
    "native_reach.py",
    "startup.py",
    "sweep.py",
    "lsp.py",
    "watching.py",
)
#: Seconds each of those scripts may take (the sweep benchmark alone: about 280 s on 2 cores).
EXTERNAL_TIMEOUT = 600.0


def external_scripts(folder: Path = REPO / "benchmarks") -> list[Path]:
    """The other benchmark scripts present, in a stable order."""
    found: list[Path] = []
    for pattern in EXTERNAL_PATTERNS:
        found.extend(sorted(folder.glob(pattern)))
    return found


def run_external(script: Path, timeout: float = EXTERNAL_TIMEOUT) -> dict[str, Any]:
    """Run one script with this interpreter; keep its exit code, time and output."""
    started = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, str(script)],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
            cwd=REPO,
        )
        code: int | None = done.returncode
        output = done.stdout + (f"\n[stderr]\n{done.stderr}" if done.returncode else "")
    except subprocess.TimeoutExpired as exc:
        code = None
        partial = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        output = f"{partial}\n[timed out after {timeout:.0f} s]"
    return {
        "script": script.name,
        "exit_code": code,
        "seconds": time.perf_counter() - started,
        "output": output.strip(),
    }


def json_safe(value: Any) -> Any:
    """NaN/inf become null (strict JSON); tuples become lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return value


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Command-line options (defaults are what ``make bench`` runs)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 50], help="chain lengths N")
    parser.add_argument("--steps", type=int, default=10_000, help="steps per chain run")
    parser.add_argument("--repeat", type=int, default=5, help="interleaved chain repetitions")
    parser.add_argument("--scenario-stop", type=float, default=None, help="simulated seconds")
    parser.add_argument("--scenario-repeat", type=int, default=3, help="runs of each loop")
    parser.add_argument("--profile-stop", type=float, default=8.0, help="seconds under cProfile")
    parser.add_argument("--skip-scenario", action="store_true")
    parser.add_argument("--skip-external", action="store_true")
    parser.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="results JSON file")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.steps, args.repeat = [1, 3], 50, 2
        args.scenario_stop, args.scenario_repeat, args.profile_stop = 0.2, 1, 0.2
    return args


def run_scenario(
    args: argparse.Namespace, console: Console, results: dict[str, Any], targets: list[Any]
) -> None:
    """The reference scenario's three measurements, tables and JSON section."""
    real = scenario.real_time(args.scenario_stop, args.scenario_repeat)
    timers = scenario.timed_breakdown(args.scenario_stop)
    profile_stop = min(args.profile_stop, real.simulated)
    prof = scenario.profile(profile_stop)
    scenario_rows = report.scenario_rows(real)
    breakdown = report.breakdown_rows(timers, prof)
    results["scenario"] = {
        "system": "systems/sign_follower.yaml",
        "rows": scenario_rows,
        "breakdown": breakdown,
        "timers_wall_s": timers.wall,
        "profile_simulated_s": profile_stop,
        "profile_wall_s": prof.wall,
        "profile_top": [{"function": f, "self_s": s} for f, s in prof.top],
    }
    rtf = scenario_rows[0]["real_time_factor"]
    targets.append(
        {
            "target": "reference scenario real-time factor",
            "value": rtf,
            "limit": "> 1",
            "met": rtf > 1.0,
        }
    )
    report.print_table(
        console,
        f"Reference scenario: {real.simulated:g} s simulated, median of {args.scenario_repeat}",
        report.SCENARIO_COLUMNS,
        scenario_rows,
    )
    report.print_table(
        console,
        f"Where the time goes (timers: one {real.simulated:g} s run, loop {timers.wall:.2f} s; "
        f"cProfile: one {profile_stop:g} s run)",
        report.BREAKDOWN_COLUMNS,
        breakdown,
    )
    report.print_table(
        console,
        "Top functions by self time under cProfile",
        (("function", "function"), ("self_s", "self s")),
        results["scenario"]["profile_top"],
    )
    compared = scenario.schedules(args.scenario_stop, args.scenario_repeat)
    results["scenario"]["schedules"] = scenario.schedule_rows(compared)
    results["scenario"]["floor"] = scenario.floor_rows(compared)
    results["scenario"]["schedules_identical"] = compared.identical
    targets.extend(scenario.schedule_targets(compared))
    scenario.print_schedules(console, compared, args.scenario_repeat, report)
    results["scenario"]["gil"] = scenario.gil_probe(quick=args.quick)
    report.print_table(
        console, "Does the call release the GIL?", scenario.GIL_COLUMNS, results["scenario"]["gil"]
    )


def main(argv: list[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Run everything requested, print the tables, write the JSON; returns the JSON document."""
    args = parse(argv)
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    results: dict[str, Any] = {
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "machine": machine.describe(),
    }
    info = results["machine"]
    console.print(
        f"[bold]fmionnx benchmarks[/bold]  {info['cpu']}, {info['cores']} cores, "
        f"{info['python']}, {info['os']}"
    )

    outcomes = chain.run(tuple(args.sizes), args.steps, args.repeat)
    rows = report.chain_rows(outcomes)
    targets = report.chain_targets(outcomes)
    results["chain"] = {"steps": args.steps, "repetitions": args.repeat, "rows": rows}
    report.print_table(
        console,
        f"Master overhead: chain of N Gain FMUs, {args.steps} steps, "
        f"median of {args.repeat} interleaved repetitions",
        report.CHAIN_COLUMNS,
        rows,
    )

    if args.skip_scenario:
        results["scenario"] = {"skipped": "--skip-scenario"}
    elif missing := scenario.missing_models():
        results["scenario"] = {"skipped": f"run `make models` first; missing {missing}"}
        console.print(f"reference scenario skipped: {results['scenario']['skipped']}")
    else:
        try:
            run_scenario(args, console, results, targets)
        except Exception as exc:  # a broken scenario must not hide the other numbers
            results["scenario"] = {"error": f"{type(exc).__name__}: {exc}"}
            console.print(f"[red]reference scenario failed:[/red] {results['scenario']['error']}")

    results["targets"] = targets
    report.print_table(console, "Targets (reported, not asserted)", report.TARGET_COLUMNS, targets)

    results["external"] = []
    if not args.skip_external and not args.quick:
        for script in external_scripts():
            console.print(f"\n[bold]{script.name}[/bold]")
            outcome = run_external(script)
            results["external"].append(outcome)
            console.print(outcome["output"], markup=False, highlight=False)

    args.out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(json_safe(results), indent=2, allow_nan=False)
    args.out.write_text(text + "\n", encoding="utf-8")
    console.print(f"\nwrote {args.out}")
    return results


if __name__ == "__main__":
    main()
