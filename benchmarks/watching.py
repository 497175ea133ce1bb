"""What watching a run costs (issue 35): the in-process loop with and without ``--profile``,
and the loop of a run that asks for nothing against the loop of an earlier tree.

Both parts step :mod:`benchmarks.chain`'s chain of N ``Gain`` FMUs with nothing recorded and
time the master's stepping loop (``RunResult.wall_time``), beside the ctypes floor measured in
the same rounds; a contender's figure is the median over the rounds of its time divided by
that round's floor, which cancels the drift of a shared machine's load.

* **This tree** (one process, repetitions interleaved, the order rotating): the plain loop
  and ``--profile`` (``RunOptions(profile=True)``: stopwatches on every phase), on the native
  kernel and on the Python path (``FMIONNX_NATIVE=0``).
* **``--against REV``**: the loop unasked (no ``--profile``, ``--rtf`` or view) of this tree
  and of the tree at git revision ``REV`` (its ``fmionnx/`` exported by ``git archive`` into a
  scratch folder), each round a fresh worker process per tree, the trees alternating which
  goes first. Both kernels are compiled at run time (``FMIONNX_NATIVE=build``) with the same
  compiler and flags, so only their sources differ. Use the revision the change started from,
  e.g. ``--against $(git merge-base main HEAD)``.

``--rtf`` and the live views are not here: pacing's cost is the sleeping it is asked to do,
and a view's cost is Rerun's or Foxglove's encoding of what was recorded (both ride on the
progress call; neither is in the loop unasked, which the second part measures).

Run: ``python benchmarks/watching.py [--n 10] [--steps 10000] [--repeat 5] [--against REV]
[--rounds 3]`` (about two minutes on 2 cores with ``--against``); ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    # Appended, not put first: a worker measuring another tree finds *its* fmionnx first (on
    # PYTHONPATH), and this folder's benchmarks after it.
    sys.path.append(str(REPO))

from rich.console import Console  # noqa: E402

from benchmarks import machine, report  # noqa: E402
from benchmarks.chain import (  # noqa: E402
    CTYPES_FLOOR,
    Chain,
    RunOnce,
    Sample,
    built_gain,
    native_kernel,
    prepare_ctypes_floor,
    system_text,
)

PLAIN = "fmionnx"
PLAIN_PYTHON = "fmionnx, Python path"
PROFILED = "fmionnx --profile"
PROFILED_PYTHON = "fmionnx --profile, Python path"
#: Contender: (native kernel, profiled).
FMIONNX_LOOPS = {
    PLAIN: (True, False),
    PLAIN_PYTHON: (False, False),
    PROFILED: (True, True),
    PROFILED_PYTHON: (False, True),
}
UNASKED = (PLAIN, PLAIN_PYTHON)


def prepare_loop(chain: Chain, *, native: bool, profile: bool) -> RunOnce:
    """One ``System.run`` per repetition, nothing recorded; ``profile`` only when asked (an
    earlier tree's options may not know it)."""
    import fmionnx
    from fmionnx.runtime.result import RunOptions, RunStatus

    folder = Path(tempfile.mkdtemp(prefix="fmionnx-watching-"))
    try:
        path = folder / "chain.yaml"
        path.write_text(system_text(chain), encoding="utf-8")
        system = fmionnx.load(path)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    options = RunOptions(record=(), **({"profile": True} if profile else {}))

    def run_once() -> Sample:
        with native_kernel(native):
            result = system.run(options=options)
        if result.status is not RunStatus.COMPLETED:
            msg = f"fmionnx run ended {result.status}: {result.error}"
            raise RuntimeError(msg)
        if result.details.get("native", False) != native:
            msg = f"the native kernel was {'not ' if native else ''}used: {result.details}"
            raise RuntimeError(msg)
        return Sample(result.wall_time, result.steps_done, 0.0)

    return run_once


def measure(chain: Chain, names: Sequence[str], repeats: int) -> dict[str, list[float]]:
    """Seconds per chain step of each contender and of the floor, ``repeats`` interleaved
    rounds (the order rotating)."""
    runners: dict[str, RunOnce] = {}
    floor = prepare_ctypes_floor(chain)
    assert not isinstance(floor, str)
    runners[CTYPES_FLOOR] = floor
    for name in names:
        native, profile = FMIONNX_LOOPS[name]
        runners[name] = prepare_loop(chain, native=native, profile=profile)
    order = list(runners)
    samples: dict[str, list[float]] = {name: [] for name in order}
    for round_ in range(repeats):
        shift = round_ % len(order)
        for name in order[shift:] + order[:shift]:
            samples[name].append(runners[name]().per_step)
    return samples


def vs_floor(samples: dict[str, list[float]], name: str) -> float:
    """Median over the rounds of the contender's time over that round's floor."""
    return statistics.median(
        own / floor for own, floor in zip(samples[name], samples[CTYPES_FLOOR], strict=True)
    )


def rows_of(samples: dict[str, list[float]]) -> list[dict[str, Any]]:
    """One row per contender: its median, its ratio to the floor and to the plain loop on
    the same path (native kernel or Python)."""
    rows = []
    for name, values in samples.items():
        row: dict[str, Any] = {
            "contender": name,
            "median_us_per_step": statistics.median(values) * 1e6,
            "vs_floor": vs_floor(samples, name),
            "vs_plain": None,
        }
        if name in FMIONNX_LOOPS:
            plain = PLAIN if FMIONNX_LOOPS[name][0] else PLAIN_PYTHON
            row["vs_plain"] = row["vs_floor"] / vs_floor(samples, plain)
        rows.append(row)
    return rows


# -- another tree ------------------------------------------------------------------------------


def export_tree(revision: str, into: Path) -> Path:
    """``fmionnx/`` of ``revision`` written under ``into`` (what PYTHONPATH will name)."""
    into.mkdir()
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", revision, "fmionnx"],
        capture_output=True, check=True,
    )  # fmt: skip
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)
    return into


def worker_samples(
    chain: Chain, tree: Path | None, repeats: int, scratch: Path
) -> dict[str, list[float]]:
    """Run this script as a worker on ``tree`` (None: this tree) and read what it measured."""
    env = dict(os.environ, FMIONNX_NATIVE="build")
    if tree is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(tree), env.get("PYTHONPATH")]))
    answer = scratch / "worker.json"
    command = [
        sys.executable, str(Path(__file__).resolve()), "--worker", str(answer),
        "--fmu", str(chain.fmu), "--unzipped", str(chain.unzipped),
        "--n", str(chain.n), "--steps", str(chain.steps), "--repeat", str(repeats),
    ]  # fmt: skip
    subprocess.run(command, env=env, check=True)
    found = json.loads(answer.read_text(encoding="utf-8"))
    expected = str((tree or REPO) / "fmionnx")
    if not found["fmionnx"].startswith(expected):
        msg = f"the worker imported {found['fmionnx']}, not the tree under {expected}"
        raise RuntimeError(msg)
    samples: dict[str, list[float]] = found["samples"]
    return samples


def against(
    chain: Chain, revision: str, rounds: int, repeats: int
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Rows of both trees' unasked loops (samples pooled over the rounds) and each round's."""
    scratch = Path(tempfile.mkdtemp(prefix="fmionnx-watching-tree-"))
    try:
        other = export_tree(revision, scratch / "tree")
        pooled: dict[str, dict[str, list[float]]] = {"this": {}, revision: {}}
        per_round: dict[str, list[dict[str, float]]] = {"this": [], revision: []}
        for round_ in range(rounds):
            trees: list[tuple[str, Path | None]] = [("this", None), (revision, other)]
            for label, tree in trees if round_ % 2 == 0 else trees[::-1]:
                samples = worker_samples(chain, tree, repeats, scratch)
                per_round[label].append({name: vs_floor(samples, name) for name in UNASKED})
                for name, values in samples.items():
                    pooled[label].setdefault(name, []).extend(values)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    rows = []
    for name in UNASKED:
        before = vs_floor(pooled[revision], name)
        after = vs_floor(pooled["this"], name)
        rows.append(
            {
                "contender": name,
                "before_rounds": ", ".join(f"{r[name]:.3g}" for r in per_round[revision]),
                "after_rounds": ", ".join(f"{r[name]:.3g}" for r in per_round["this"]),
                "before_vs_floor": before,
                "after_vs_floor": after,
                "after_vs_before": after / before,
            }
        )
    return rows, per_round


# -- the command -------------------------------------------------------------------------------

THIS_TREE_COLUMNS = (
    ("contender", "loop"),
    ("median_us_per_step", "µs/step (median)"),
    ("vs_floor", "x floor"),
    ("vs_plain", "x its plain loop"),
)
AGAINST_COLUMNS = (
    ("contender", "loop, nothing asked"),
    ("before_rounds", "before: x floor, each round"),
    ("after_rounds", "after: x floor, each round"),
    ("before_vs_floor", "before x floor"),
    ("after_vs_floor", "after x floor"),
    ("after_vs_before", "after / before"),
)


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """The command line (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=10, help="FMUs in the chain")
    parser.add_argument("--steps", type=int, default=10_000, help="steps per run")
    parser.add_argument("--repeat", type=int, default=5, help="interleaved repetitions")
    parser.add_argument("--against", metavar="REV", help="git revision to compare the loop with")
    parser.add_argument("--rounds", type=int, default=3, help="worker rounds per tree")
    parser.add_argument("--quick", action="store_true", help="a smoke run")
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--fmu", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--unzipped", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.quick:
        args.n, args.steps, args.repeat, args.rounds = 3, 300, 2, 1
    return args


def work(args: argparse.Namespace) -> None:
    """``--worker FILE``: measure the unasked loops of whichever fmionnx imports; write JSON."""
    import fmionnx

    chain = Chain(args.fmu, args.unzipped, args.n, args.steps)
    samples = measure(chain, UNASKED, args.repeat)
    answer = {"fmionnx": str(Path(fmionnx.__file__).resolve().parent), "samples": samples}
    args.worker.write_text(json.dumps(answer), encoding="utf-8")


def main(argv: Sequence[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure and print the tables; returns their rows."""
    args = parse(argv)
    if args.worker is not None:
        work(args)
        return {}
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    console.print(machine.headline("fmionnx: what watching a run costs", machine.describe()))
    results: dict[str, Any] = {}
    folder = Path(tempfile.mkdtemp(prefix="fmionnx-watching-fmu-"))
    try:
        with built_gain(folder) as (fmu, unzipped):
            chain = Chain(fmu, unzipped, args.n, args.steps)
            samples = measure(chain, list(FMIONNX_LOOPS), args.repeat)
            rows = rows_of(samples)
            results["this_tree"] = rows
            report.print_table(
                console,
                f"Chain of {args.n} Gain FMUs, {args.steps} steps, nothing recorded, "
                f"{args.repeat} interleaved repetitions; x floor: median of each round's ratio",
                THIS_TREE_COLUMNS,
                rows,
            )
            if args.against:
                against_rows, _ = against(chain, args.against, args.rounds, args.repeat)
                results["against"] = {"revision": args.against, "rows": against_rows}
                report.print_table(
                    console,
                    f"The loop unasked, this tree against {args.against}: {args.rounds} rounds "
                    f"of a worker per tree ({args.repeat} repetitions each, trees alternating); "
                    "FMIONNX_NATIVE=build for both",
                    AGAINST_COLUMNS,
                    against_rows,
                )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return results


if __name__ == "__main__":
    main()
