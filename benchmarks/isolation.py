"""What ``--isolate`` costs: models in child processes against the same run in-process.

``RunOptions(isolate=...)`` (the CLI's default is ``--isolate fmus``) runs each named
component's model in a child process of its own; port values go through shared memory and
every step is one pipe round trip. That buys crash and hang safety at a price per step (two
context switches at least, on a machine whose cores are shared) and a price per run (a Python
process spawned and the model loaded in it). This script measures both prices, side by side
in one run, the two modes interleaved (round *r* starts with the other mode than round
*r - 1*) so that drifting machine load hits both alike; the tables report medians.

1. **The chain** (:mod:`benchmarks.chain`): N = 4 ``Gain`` FMUs in a row, 20 000 base steps,
   nothing recorded. In-process the native kernel steps the four FMUs with one C call per
   step; isolated, every FMU is a child process. This is the worst case for isolation: the
   models do almost nothing, so the per-step cost is almost all round trips. The loop time is
   the master's ``RunResult.wall_time`` (after preparation); *start-up* is the rest of
   ``System.run`` (validation, preparation - for isolated components the process spawn and
   model load - and termination).
2. **The reference scenario** ``systems/sign_follower.yaml`` (shortened; default 8 s
   simulated), default recording as ``fmionnx run`` does it, with nothing isolated against
   its two FMUs (``odometry``, ``tracker``) isolated - what ``--isolate fmus`` does to it.
   Target: the isolated loop within 1.5x of the in-process loop. The recorded signals of
   every run are compared with the first in-process run's: isolation must not change results.

Both run a third mode too: isolated, with the step hand-over in Python (``FMIONNX_NATIVE=0``)
instead of the native kernel's (``fmionnx/runtime/isolated/handover.py``), to show what the
kernel's ends of the round trip save. With every FMU isolated, the switch changes nothing else.

Targets are reported, not asserted (a timing depends on the machine and its load). Run:
``python benchmarks/isolation.py`` (about a minute on 2 cores), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

os.environ.setdefault("MUJOCO_GL", "egl")  # as the other benchmarks do; set before mujoco loads

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402

from benchmarks import chain, machine, report, scenario  # noqa: E402

INPROCESS = "in-process"
ISOLATED = "isolated"
ISOLATED_PYTHON = "isolated, hand-over in Python"
#: What makes a mode's hand-over Python's: the native kernel switched off.
PYTHON_HANDOVER = (("FMIONNX_NATIVE", "0"),)
CHAIN_N = 4
#: The reference scenario's FMUs: what ``--isolate fmus`` (the CLI default) isolates there.
SCENARIO_ISOLATED = frozenset({"odometry", "tracker"})
#: Isolated loop / in-process loop on the reference scenario.
SCENARIO_TARGET = 1.5
#: Marks an isolated component's process on its command line (``python -m ...``).
CHILD_MODULE = "fmionnx.runtime.isolated.child"

Row = dict[str, Any]


@dataclass(frozen=True)
class Sample:
    """One timed ``System.run``: the master's loop time, the whole call, base steps done."""

    loop_s: float
    total_s: float
    steps: int

    @property
    def startup_s(self) -> float:
        """Everything but the loop: validation, preparation (spawn, load), termination."""
        return self.total_s - self.loop_s

    @property
    def us_per_step(self) -> float:
        """Loop microseconds per base step."""
        return self.loop_s / self.steps * 1e6 if self.steps else float("nan")


@dataclass
class Mode:
    """Every repetition of one way of running the same system."""

    name: str
    isolate: frozenset[str]
    #: Environment variables set while this mode runs.
    env: tuple[tuple[str, str], ...] = ()
    samples: list[Sample] = field(default_factory=list)
    #: Whether the native kernel stepped FMUs (``RunResult.details["native"]``).
    native: bool | None = None
    #: Chain: the tail ended at ``2**N``; scenario: signals equal to the reference run's.
    correct: bool | None = None

    def median(self, what: Callable[[Sample], float]) -> float:
        """Median of one quantity over the repetitions (NaN when none ran)."""
        return statistics.median(what(s) for s in self.samples) if self.samples else float("nan")

    @property
    def loop_s(self) -> float:
        """Median loop seconds."""
        return self.median(lambda s: s.loop_s)

    @property
    def startup_s(self) -> float:
        """Median start-up seconds."""
        return self.median(lambda s: s.startup_s)

    @property
    def us_per_step(self) -> float:
        """Median loop microseconds per base step."""
        return self.median(lambda s: s.us_per_step)


def timed(system: Any, options: Any) -> tuple[Sample, Any]:
    """One completed ``System.run`` timed whole; a run that does not complete raises."""
    from fmionnx.runtime.result import RunStatus

    started = time.perf_counter()
    result = system.run(options=options)
    total = time.perf_counter() - started
    if result.status is not RunStatus.COMPLETED:
        msg = f"{system.name} run ended {result.status}: {result.error}"
        raise RuntimeError(msg)
    return Sample(result.wall_time, total, result.steps_done), result


def interleaved(
    modes: Sequence[Mode], repeats: int, run_once: Callable[[Mode], tuple[Sample, Any]]
) -> list[Any]:
    """``repeats`` rounds of every mode, the starting mode alternating; returns the results."""
    results = []
    for round_ in range(repeats):
        shift = round_ % len(modes)
        for mode in [*modes[shift:], *modes[:shift]]:
            with environment(mode.env):
                sample, result = run_once(mode)
            mode.samples.append(sample)
            mode.native = bool(result.details.get("native"))
            results.append((mode, result))
    return results


@contextmanager
def environment(variables: Sequence[tuple[str, str]]) -> Iterator[None]:
    """``variables`` set in this process's environment for a while (isolated children take it)."""
    before = {name: os.environ.get(name) for name, _ in variables}
    os.environ.update(dict(variables))
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def handover(mode: Mode) -> str:
    """Who makes an isolated mode's step round trips: the native kernel or Python."""
    if not mode.isolate:
        return "-"
    return "Python" if mode.env == PYTHON_HANDOVER else "kernel"


def ratio(a: float | None, b: float | None) -> float | None:
    """``a / b``, or None when either is missing or ``b`` is zero."""
    if a is None or b is None or b == 0 or np.isnan(a) or np.isnan(b):
        return None
    return a / b


def live_children() -> list[int]:
    """Isolated components' processes still alive after the runs (there should be none)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError, UnicodeDecodeError):
            continue
        state, parent = fields[0], int(fields[1])
        if parent == os.getpid() and CHILD_MODULE in cmdline and state != "Z":
            found.append(int(entry.name))
    return found


# -- the chain -----------------------------------------------------------------------------------


def chain_modes(n: int, steps: int, repeats: int, work: Path | None = None) -> list[Mode]:
    """The Gain chain in-process and with every FMU isolated, interleaved."""
    import fmionnx
    from fmionnx.core.types import PortRef
    from fmionnx.runtime.result import RunOptions

    folder = work or Path(tempfile.mkdtemp(prefix="fmionnx-isolation-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        with chain.built_gain(folder) as (fmu, unzipped):
            case = chain.Chain(fmu, unzipped, n, steps)
            path = folder / "chain.yaml"
            path.write_text(chain.system_text(case), encoding="utf-8")
            system = fmionnx.load(path)
            names = frozenset(f"g{i}" for i in range(n))
            modes = [
                Mode(INPROCESS, frozenset()),
                Mode(ISOLATED, names),
                Mode(ISOLATED_PYTHON, names, PYTHON_HANDOVER),
            ]
            tail = PortRef(f"g{n - 1}", "y")
            for mode in modes:  # untimed: both modes compute 2**N at the tail
                check = system.run(
                    stop_time=3 * case.step,
                    signals=(tail,),
                    options=RunOptions(isolate=mode.isolate),
                )
                mode.correct = float(check[f"{tail.component}.y"][-1]) == case.expected
            options = {m.name: RunOptions(record=(), isolate=m.isolate) for m in modes}
            interleaved(modes, repeats, lambda mode: timed(system, options[mode.name]))
    finally:
        if work is None:
            shutil.rmtree(folder, ignore_errors=True)
    return modes


def chain_rows(modes: Sequence[Mode], n: int) -> list[Row]:
    """One row per mode: µs per step, loop and start-up seconds, ratio to in-process."""
    base = next((m for m in modes if m.name == INPROCESS), None)
    rows = []
    for mode in modes:
        per_step = mode.us_per_step
        rows.append(
            {
                "mode": mode.name,
                "isolated": ", ".join(sorted(mode.isolate)) or "-",
                "native": None if mode.native is None else ("yes" if mode.native else "no"),
                "handover": handover(mode),
                "steps": mode.samples[0].steps if mode.samples else None,
                "median_us_per_step": per_step,
                "min_us_per_step": min((s.us_per_step for s in mode.samples), default=None),
                "us_per_fmu_step": per_step / n,
                "median_loop_s": mode.loop_s,
                "median_startup_s": mode.startup_s,
                "vs_inprocess": ratio(per_step, base.us_per_step if base else None),
                "correct": mode.correct,
                "samples_us_per_step": [s.us_per_step for s in mode.samples],
                "samples_startup_s": [s.startup_s for s in mode.samples],
            }
        )
    return rows


CHAIN_COLUMNS = (
    ("mode", "mode"),
    ("isolated", "isolated components"),
    ("native", "native kernel in-process"),
    ("handover", "hand-over"),
    ("median_us_per_step", "µs/step (median)"),
    ("min_us_per_step", "µs/step (min)"),
    ("us_per_fmu_step", "µs per FMU-step"),
    ("median_loop_s", "loop s"),
    ("median_startup_s", "start-up s"),
    ("vs_inprocess", "x in-process"),
    ("correct", "tail = 2^N"),
)


# -- the reference scenario ----------------------------------------------------------------------


def _same_signals(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Same columns, every value equal (NaN equal to NaN)."""
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


def scenario_modes(stop_time: float, repeats: int) -> tuple[float, list[Mode]]:
    """The reference scenario in-process and with its FMUs isolated; simulated seconds too."""
    from fmionnx.runtime.result import RunOptions

    system = scenario.load_system(stop_time)
    simulated = float(system.compiled.run.stop) - float(system.compiled.run.start)
    modes = [
        Mode(INPROCESS, frozenset()),
        Mode(ISOLATED, SCENARIO_ISOLATED),
        Mode(ISOLATED_PYTHON, SCENARIO_ISOLATED, PYTHON_HANDOVER),
    ]
    options = {m.name: RunOptions(isolate=m.isolate) for m in modes}
    results = interleaved(modes, repeats, lambda mode: timed(system, options[mode.name]))
    reference = next(r.signals for m, r in results if m.name == INPROCESS)
    for mode in modes:
        mode.correct = all(_same_signals(reference, r.signals) for m, r in results if m is mode)
    return simulated, modes


def scenario_rows(modes: Sequence[Mode], simulated: float) -> list[Row]:
    """One row per mode: loop seconds, real-time factor, start-up, ratio to in-process."""
    base = next((m for m in modes if m.name == INPROCESS), None)
    rows = []
    for mode in modes:
        loop = mode.loop_s
        rows.append(
            {
                "mode": mode.name,
                "isolated": ", ".join(sorted(mode.isolate)) or "-",
                "handover": handover(mode),
                "simulated_s": simulated,
                "median_loop_s": loop,
                "min_loop_s": min((s.loop_s for s in mode.samples), default=None),
                "real_time_factor": simulated / loop if loop > 0 else None,
                "median_startup_s": mode.startup_s,
                "vs_inprocess": ratio(loop, base.loop_s if base else None),
                "correct": mode.correct,
                "samples_loop_s": [s.loop_s for s in mode.samples],
                "samples_startup_s": [s.startup_s for s in mode.samples],
            }
        )
    return rows


SCENARIO_COLUMNS = (
    ("mode", "mode"),
    ("isolated", "isolated components"),
    ("handover", "hand-over"),
    ("simulated_s", "simulated s"),
    ("median_loop_s", "loop s (median)"),
    ("min_loop_s", "loop s (min)"),
    ("real_time_factor", "real-time factor"),
    ("median_startup_s", "start-up s"),
    ("vs_inprocess", "x in-process"),
    ("correct", "same results"),
)


# -- main ----------------------------------------------------------------------------------------


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Options (defaults are what ``make bench`` runs)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--n", type=int, default=CHAIN_N, help="FMUs in the chain")
    parser.add_argument("--steps", type=int, default=20_000, help="base steps per chain run")
    parser.add_argument("--repeat", type=int, default=5, help="interleaved chain repetitions")
    parser.add_argument("--scenario-stop", type=float, default=8.0, help="simulated seconds")
    parser.add_argument("--scenario-repeat", type=int, default=5, help="runs of each mode")
    parser.add_argument("--skip-scenario", action="store_true")
    parser.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run")
    args = parser.parse_args(argv)
    if args.quick:
        args.steps, args.repeat = 200, 2
        args.scenario_stop, args.scenario_repeat = 0.5, 1
    return args


def main(argv: Sequence[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure, print the tables; returns the rows and targets (what the tables show)."""
    args = parse(argv)
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    info = machine.describe()
    console.print(machine.headline("fmionnx isolation cost", info))
    results: dict[str, Any] = {}
    targets: list[Row] = []

    modes = chain_modes(args.n, args.steps, args.repeat)
    results["chain"] = chain_rows(modes, args.n)
    report.print_table(
        console,
        f"Chain of {args.n} Gain FMUs, {args.steps} steps, nothing recorded, "
        f"median of {args.repeat} interleaved repetitions",
        CHAIN_COLUMNS,
        results["chain"],
    )

    if args.skip_scenario:
        results["scenario"] = {"skipped": "--skip-scenario"}
    elif missing := scenario.missing_models():
        results["scenario"] = {"skipped": f"run `make models` first; missing {missing}"}
        console.print(f"reference scenario skipped: {results['scenario']['skipped']}")
    else:
        simulated, modes = scenario_modes(args.scenario_stop, args.scenario_repeat)
        rows = scenario_rows(modes, simulated)
        results["scenario"] = rows
        report.print_table(
            console,
            f"Reference scenario (systems/sign_follower.yaml), {simulated:g} s simulated, "
            f"median of {args.scenario_repeat} interleaved runs",
            SCENARIO_COLUMNS,
            rows,
        )
        measured = next(r["vs_inprocess"] for r in rows if r["mode"] == ISOLATED)
        targets.append(
            {
                "target": "reference scenario: isolated FMUs / in-process, loop time",
                "value": measured,
                "limit": f"<= {SCENARIO_TARGET:g}",
                "met": None if measured is None else measured <= SCENARIO_TARGET,
            }
        )
        report.print_table(
            console, "Targets (reported, not asserted)", report.TARGET_COLUMNS, targets
        )
    results["targets"] = targets
    results["leftover_children"] = live_children()
    if results["leftover_children"]:
        console.print(f"[red]isolated processes still alive:[/red] {results['leftover_children']}")
    return results


if __name__ == "__main__":
    main()
