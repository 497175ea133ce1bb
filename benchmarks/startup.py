"""Start-up and end to end: ``fmionnx`` against FMPy's own command line and against the time
to import the libraries each command needs, as a user times them.

Each question is answered by running the commands side by side in one run, the contenders
interleaved (round *r* rotates their order) so that drifting machine load hits all alike; the
tables report medians and ratios.

1. **Start-up**: ``fmionnx --help`` against ``fmpy --help`` (both console scripts of this
   interpreter's environment). Target: no slower (ratio <= 1).
2. **One external FMU end to end**: the fixture ``Integrator`` FMU (``der(x) = u``, built from
   C in ``tests/fixtures/fmus``) co-simulated with ``u = 1`` for 200 000 steps of 0.01 s, its
   output ``x`` written to CSV at every step: ``fmpy simulate`` against ``fmionnx run
   MODEL.fmu`` as a user gets it by default (a lone FMU: the guardian, the whole run in one
   forked child whose native loop steps the FMU and records into shared memory, while this
   process formats results.csv, the child taking a share from the end once its run is done:
   :mod:`fmionnx.runtime.guardian`), with an explicit ``--isolate fmus`` (the FMU in a child
   process of its own, one pipe round trip per step; the default for systems of several
   components), with ``--isolate guardian`` and with ``--isolate none`` (the FMU in
   fmionnx's own process), each with its compile read back from the compile cache (from the
   second run of an unchanged FMU on), and the default as a first run finds it
   (``FMIONNX_COMPILE_CACHE=0 FMIONNX_FMU_INTERFACES=0``). Wall time of
   the whole command: interpreter start, imports, compile, simulation, CSV. The CSV files
   must agree (checked every round): the same times, and ``x`` within 1e-9 (FMPy hands the
   FMU step sizes computed from its time grid, fmionnx the constant step, so the sums
   differ in the last bits). Target (issue 32): <= 0.4x ``fmpy simulate`` with the default.
   Beside it, ``python -c "import numpy, fmpy"``: what the command needs to import at all,
   and the peers installed here, each as a whole process writing the same CSV (times within
   1e-12, their own time grid): a libcosimpy script (:mod:`benchmarks.peer_libcosim`). Ecos
   (``ecospy``) and OMSimulator's CLI are named with the reason they were not measured (here:
   ecospy's native library needs ``libtbb.so.12``, which is not installed; OMSimulator's PyPI
   package downloads its binaries from build.openmodelica.org while it builds, which this
   machine cannot reach).
3. **Validate**: ``fmionnx validate systems/sign_follower.yaml`` of the unchanged reference
   system (its compile read back from the compile cache, as a CI job or a user gets it the
   second time), and with ``FMIONNX_COMPILE_CACHE=0`` (compiled every time), against
   ``python -c "import numpy"``. Target: <= 4x the import.
4. **The reference run's time outside its loop**: ``fmionnx run systems/sign_follower.yaml``
   with the defaults a user gets (FMUs isolated, results and plots written), its whole wall
   time minus the loop's (``run.json``'s ``wall_time``), against ``python -c "import numpy,
   onnxruntime, mujoco, fmpy"``. Target: <= 1.5x the import.

The commands use a cache folder of their own (``FMIONNX_CACHE``), filled by the untimed round.

Both programs run as installed: with their bytecode cached (an environment that sets
``PYTHONDONTWRITEBYTECODE`` would have fmionnx, installed editable from source, recompile every
module at every start while FMPy's wheel came with its bytecode). One untimed round runs
first to write the caches.

Targets are reported, not asserted. Run ``python benchmarks/startup.py`` (a few minutes on 2
cores: the isolated runs are the slow ones), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402

from benchmarks import machine, report  # noqa: E402

INTEGRATOR_SOURCE = REPO / "tests" / "fixtures" / "fmus" / "Integrator"
STEP = 0.01
STEPS = 200_000
HELP_TARGET = 1.0
END_TO_END_TARGET = 0.4
VALIDATE_TARGET = 4.0
OUTSIDE_LOOP_TARGET = 1.5
REFERENCE = REPO / "systems" / "sign_follower.yaml"

IMPORT_NUMPY = 'python -c "import numpy"'
IMPORT_FMU = 'python -c "import numpy, fmpy"'
IMPORT_RUN = 'python -c "import numpy, onnxruntime, mujoco, fmpy"'
VALIDATE = "fmionnx validate (compile cache)"
VALIDATE_COLD = "fmionnx validate (FMIONNX_COMPILE_CACHE=0)"
RUN_REFERENCE = "fmionnx run sign_follower.yaml (outside its loop)"

FMPY = "fmpy"
FMIONNX = "fmionnx"
FMPY_SIMULATE = "fmpy simulate"
RUN_DEFAULT = "fmionnx run (default: the guardian)"
RUN_DEFAULT_COLD = "fmionnx run (default, a first run: caches off)"
RUN_FMUS = "fmionnx run --isolate fmus"
RUN_NONE = "fmionnx run --isolate none"
RUN_GUARDIAN = "fmionnx run --isolate guardian"
LIBCOSIM_SCRIPT = "libcosimpy script (benchmarks/peer_libcosim.py)"

COLUMNS = (
    ("contender", "command"),
    ("median_s", "wall s (median)"),
    ("min_s", "wall s (min)"),
    ("vs_fmpy", "x FMPy"),
    ("cpu_s", "CPU s (median)"),
    ("cpu_vs_fmpy", "x FMPy (CPU)"),
    ("runs", "runs"),
    ("same_values", "CSV agrees"),
)


@dataclass
class Contender:
    """A command line and its wall times (and, for simulations, its CSV file)."""

    name: str
    argv: list[str]
    csv: Path | None = None
    seconds: list[float] = field(default_factory=list)
    #: User + system CPU seconds of the command and every process it waited for.
    cpu: list[float] = field(default_factory=list)
    same_values: bool | None = None
    #: Whether its times must equal FMPy's bit for bit (a peer computes its own time grid).
    exact_times: bool = True
    #: Variables set for the command.
    env: dict[str, str] = field(default_factory=dict)
    #: A run's ``run.json``: its loop's wall time is taken off the command's (outside the loop).
    run_json: Path | None = None
    #: Seconds of the loop of each run (with ``run_json``).
    loops: list[float] = field(default_factory=list)

    def median(self) -> float:
        return statistics.median(self.seconds)


def console_script(name: str) -> list[str]:
    """``name``'s console script beside this interpreter, else ``python -m`` its module."""
    script = Path(sys.executable).parent / name
    if script.exists():
        return [str(script)]
    module = {"fmionnx": "fmionnx", "fmpy": "fmpy.cli"}[name]
    return [sys.executable, "-m", module]


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed_run(
    argv: Sequence[str], cwd: Path, extra: dict[str, str] | None = None
) -> tuple[float, float]:
    """Wall and CPU seconds of one command, which must succeed (its output is discarded).

    CPU time (of the command and every process it waited for) is what load on a shared
    machine disturbs least; wall time is what the user waits.
    """
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(extra or {})
    cpu = _children_cpu()
    started = time.perf_counter()
    done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    cpu = _children_cpu() - cpu
    if done.returncode != 0:
        msg = f"`{' '.join(argv)}` exited {done.returncode}: {done.stderr.strip()[-800:]}"
        raise RuntimeError(msg)
    return seconds, cpu


def interleaved(contenders: Sequence[Contender], rounds: int, cwd: Path) -> None:
    """Each round runs every contender once, starting one further along each time; an
    untimed round first (bytecode caches, the page cache)."""
    for contender in contenders:
        timed_run(contender.argv, cwd, contender.env)
    for r in range(rounds):
        shift = r % len(contenders)
        for contender in [*contenders[shift:], *contenders[:shift]]:
            seconds, cpu = timed_run(contender.argv, cwd, contender.env)
            contender.seconds.append(seconds)
            contender.cpu.append(cpu)
            if contender.run_json is not None:
                contender.loops.append(_loop_seconds(contender.run_json))
            if contender.csv is not None:
                contender.same_values = _same_as_fmpy(contenders, contender)


def _loop_seconds(run_json: Path) -> float:
    """The loop's wall time a run recorded in its ``run.json``."""
    import json

    return float(json.loads(run_json.read_text(encoding="utf-8"))["wall_time"])


def python_import(name: str, modules: str) -> Contender:
    """``python -c "import MODULES"`` in this environment (its interpreter start included, as
    every command's)."""
    return Contender(name, [sys.executable, "-c", f"import {modules}"])


def _columns(path: Path) -> np.ndarray:
    """(time, x) from either program's CSV (FMPy quotes its header)."""
    return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def _same_as_fmpy(contenders: Sequence[Contender], contender: Contender) -> bool | None:
    reference = next((c for c in contenders if c.name == FMPY_SIMULATE), None)
    if reference is None or reference.csv is None or not reference.csv.exists():
        return None
    if contender is reference:
        return True
    assert contender.csv is not None
    ours, theirs = _columns(contender.csv), _columns(reference.csv)
    if ours.shape != theirs.shape:
        return False
    if contender.exact_times and ours[:, 0].tobytes() != theirs[:, 0].tobytes():
        return False
    if not np.allclose(ours[:, 0], theirs[:, 0], rtol=1e-12, atol=1e-12):
        return False
    return bool(np.allclose(ours[:, 1], theirs[:, 1], rtol=1e-9, atol=1e-9))


def build_integrator(folder: Path) -> Path:
    """The fixture FMU compiled for this platform into ``folder``."""
    from fmionnx.kinds.fmu.build import build_fmu

    fmu = folder / "Integrator.fmu"
    build_fmu(INTEGRATOR_SOURCE, fmu)
    return fmu


#: What a lone FMU's first run finds: neither its compile nor its interface kept.
FIRST_RUN = {"FMIONNX_COMPILE_CACHE": "0", "FMIONNX_FMU_INTERFACES": "0"}


def end_to_end_contenders(fmu: Path, work: Path, steps: int, cache: Path) -> list[Contender]:
    """``fmionnx run`` of the FMU in each isolation, its compile read back from the compile
    cache (``cache``, filled by the untimed round), as a user gets it from the second run on;
    and the default with the compile cache and the kept FMU interfaces off (:data:`FIRST_RUN`),
    as the first run of a new FMU is."""
    stop = f"{steps * STEP:g}"
    cached = {"FMIONNX_CACHE": str(cache)}
    fmpy_csv = work / "fmpy.csv"
    fmpy_argv = [
        *console_script("fmpy"), "simulate", str(fmu), "--stop-time", stop,
        "--step-size", str(STEP), "--output-interval", str(STEP), "--start-values", "u", "1",
        "--output-variables", "x", "--output-file", str(fmpy_csv),
    ]  # fmt: skip
    run = [*console_script("fmionnx"), "run", str(fmu), "-q", "--stop-time", stop]
    run += ["--step", str(STEP), "-p", "u=1"]
    return [
        Contender(FMPY_SIMULATE, fmpy_argv, fmpy_csv),
        Contender(RUN_DEFAULT, [*run, "--out", str(work / "default")], work / "default" / "results.csv", env=cached),
        Contender(RUN_DEFAULT_COLD, [*run, "--out", str(work / "cold")], work / "cold" / "results.csv", env={**cached, **FIRST_RUN}),
        Contender(RUN_FMUS, [*run, "--out", str(work / "fmus"), "--isolate", "fmus"], work / "fmus" / "results.csv", env=cached),
        Contender(RUN_GUARDIAN, [*run, "--out", str(work / "guardian"), "--isolate", "guardian"], work / "guardian" / "results.csv", env=cached),
        Contender(RUN_NONE, [*run, "--out", str(work / "none"), "--isolate", "none"], work / "none" / "results.csv", env=cached),
    ]  # fmt: skip


def peer_contenders(fmu: Path, work: Path, steps: int) -> tuple[list[Contender], list[str]]:
    """The peers installed here, each a whole process writing the same CSV, and a line for each
    peer that cannot run here saying why."""
    from benchmarks import chain

    found, missing = [], []
    problem = chain.libcosim_problem()
    if problem is None:
        csv = work / "libcosim.csv"
        argv = [sys.executable, str(REPO / "benchmarks" / "peer_libcosim.py"), str(fmu), str(csv)]
        found.append(
            Contender(LIBCOSIM_SCRIPT, [*argv, str(steps), str(STEP)], csv, exact_times=False)
        )
    else:
        missing.append(f"{LIBCOSIM_SCRIPT}: not measured ({problem})")
    try:
        import ecospy  # noqa: F401
    except Exception as exc:  # not installed, or its native library does not load
        missing.append(f"Ecos (ecospy): not measured ({type(exc).__name__}: {exc})")
    else:
        missing.append("Ecos (ecospy): imports here, but this benchmark has no Ecos runner yet")
    if shutil.which("OMSimulator") is None:
        missing.append(
            "OMSimulator's CLI: not measured (not installed here: its PyPI package builds by "
            "downloading binaries from build.openmodelica.org, which this machine cannot reach)"
        )
    else:
        missing.append(
            "OMSimulator's CLI: on PATH, but this benchmark has no OMSimulator runner yet"
        )
    return found, missing


def rows(contenders: Sequence[Contender], reference: str) -> list[dict[str, Any]]:
    """One row per contender, each ratio to ``reference`` (for a run with a ``run.json``, its
    time outside the loop: the command's wall time minus the loop's, round by round)."""
    reference_contender = next(c for c in contenders if c.name == reference)
    base = reference_contender.median()
    base_cpu = statistics.median(reference_contender.cpu)
    found = []
    for c in contenders:
        row = {
            "contender": c.name,
            "median_s": c.median(),
            "min_s": min(c.seconds),
            "vs_fmpy": c.median() / base if base else None,
            "cpu_s": statistics.median(c.cpu),
            "cpu_vs_fmpy": statistics.median(c.cpu) / base_cpu if base_cpu else None,
            "runs": len(c.seconds),
            "same_values": c.same_values,
        }
        if c.loops:
            outside = [w - loop for w, loop in zip(c.seconds, c.loops, strict=True)]
            row["loop_s"] = statistics.median(c.loops)
            row["median_s"] = statistics.median(outside)
            row["min_s"] = min(outside)
            row["vs_fmpy"] = row["median_s"] / base if base else None
            row["cpu_s"] = row["cpu_vs_fmpy"] = None  # the loop's CPU is in the command's
        found.append(row)
    return found


def validate_contenders(cache: Path) -> list[Contender]:
    """``validate`` of the reference system, from the cache and compiled, and its import."""
    validate = [*console_script("fmionnx"), "validate", str(REFERENCE)]
    return [
        python_import(IMPORT_NUMPY, "numpy"),
        Contender(VALIDATE, validate, env={"FMIONNX_CACHE": str(cache)}),
        Contender(VALIDATE_COLD, validate, env={"FMIONNX_COMPILE_CACHE": "0"}),
    ]


def reference_contenders(work: Path, cache: Path, stop: float | None) -> list[Contender]:
    """The reference run as a user runs it (defaults), and the import of what it needs."""
    out = work / "reference"
    run = [*console_script("fmionnx"), "run", str(REFERENCE), "-q", "--out", str(out), "--force"]
    if stop is not None:
        run += ["--stop-time", f"{stop:g}", "--no-checks"]
    return [
        python_import(IMPORT_RUN, "numpy, onnxruntime, mujoco, fmpy"),
        Contender(RUN_REFERENCE, run, env={"FMIONNX_CACHE": str(cache)}, run_json=out / "run.json"),
    ]


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes (a smoke run)")
    parser.add_argument("--steps", type=int, default=None, help=f"FMU steps (default {STEPS})")
    parser.add_argument("--repeat", type=int, default=None, help="rounds (default 5)")
    parser.add_argument(
        "--reference-stop", type=float, default=None, help="stop time of the reference run"
    )
    parser.add_argument("--skip-reference", action="store_true", help="no reference run")
    args = parser.parse_args(argv)
    if args.quick and args.reference_stop is None:
        args.reference_stop = 0.2
    args.steps = args.steps or (200 if args.quick else STEPS)
    args.repeat = args.repeat or (1 if args.quick else 5)
    args.help_repeat = 2 if args.quick else 15
    return args


def main(argv: Sequence[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure, print the tables; returns the rows and targets (what the tables show)."""
    args = parse(argv)
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    info = machine.describe()
    console.print(machine.headline("fmionnx start-up and end to end", info))
    results: dict[str, Any] = {"machine": info}
    work = Path(tempfile.mkdtemp(prefix="fmionnx-startup-"))
    try:
        helps = [
            Contender(FMPY, [*console_script("fmpy"), "--help"]),
            Contender(FMIONNX, [*console_script("fmionnx"), "--help"]),
        ]
        interleaved(helps, args.help_repeat, work)
        results["help"] = rows(helps, FMPY)
        report.print_table(
            console,
            f"`--help`, median of {args.help_repeat} interleaved runs",
            [c for c in COLUMNS if c[0] != "same_values"],
            results["help"],
        )
        fmu = build_integrator(work)
        cache = work / "cache"
        peers, results["peers_missing"] = peer_contenders(fmu, work, args.steps)
        runs = [
            *end_to_end_contenders(fmu, work, args.steps, cache),
            *peers,
            python_import(IMPORT_FMU, "numpy, fmpy"),
        ]
        interleaved(runs, args.repeat, work)
        results["end_to_end"] = rows(runs, FMPY_SIMULATE)
        report.print_table(
            console,
            f"One FMU end to end: Integrator, {args.steps} steps of {STEP:g} s to CSV, "
            f"median of {args.repeat} interleaved runs",
            COLUMNS,
            results["end_to_end"],
        )
        for line in results["peers_missing"]:
            console.print(f"  {line}")
        checks = validate_contenders(cache)
        interleaved(checks, args.repeat, work)
        results["validate"] = rows(checks, IMPORT_NUMPY)
        report.print_table(
            console,
            f"Validate the reference system, median of {args.repeat} interleaved runs",
            IMPORT_COLUMNS,
            results["validate"],
        )
        results["reference"] = []
        if not args.skip_reference:
            reference = reference_contenders(work, cache, args.reference_stop)
            interleaved(reference, args.repeat, work)
            results["reference"] = rows(reference, IMPORT_RUN)
            stop = "32 s" if args.reference_stop is None else f"{args.reference_stop:g} s"
            report.print_table(
                console,
                f"The reference run ({stop}, defaults: FMUs isolated, results and plots): "
                f"time outside its loop, median of {args.repeat} interleaved runs",
                IMPORT_COLUMNS,
                results["reference"],
            )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    found = [*results["help"], *results["end_to_end"], *results["validate"], *results["reference"]]
    by_name = {r["contender"]: r for r in found}
    targets = [
        _target("fmionnx --help / fmpy --help", by_name[FMIONNX]["vs_fmpy"], HELP_TARGET),
        _target(
            "fmionnx run (default) / fmpy simulate",
            by_name[RUN_DEFAULT]["vs_fmpy"],
            END_TO_END_TARGET,
        ),
        _target(
            "fmionnx run (default, a first run) / fmpy simulate",
            by_name[RUN_DEFAULT_COLD]["vs_fmpy"],
            END_TO_END_TARGET,
        ),
        _target(
            "fmionnx run --isolate fmus / fmpy simulate",
            by_name[RUN_FMUS]["vs_fmpy"],
            END_TO_END_TARGET,
        ),
        _target(
            "fmionnx run --isolate guardian / fmpy simulate",
            by_name[RUN_GUARDIAN]["vs_fmpy"],
            END_TO_END_TARGET,
        ),
        _target(
            "fmionnx run --isolate none / fmpy simulate",
            by_name[RUN_NONE]["vs_fmpy"],
            END_TO_END_TARGET,
        ),
        _target(f"{VALIDATE} / {IMPORT_NUMPY}", by_name[VALIDATE]["vs_fmpy"], VALIDATE_TARGET),
        _target(
            f"{VALIDATE_COLD} / {IMPORT_NUMPY}", by_name[VALIDATE_COLD]["vs_fmpy"], VALIDATE_TARGET
        ),
    ]
    if results["reference"]:
        targets.append(
            _target(
                f"reference run outside its loop / {IMPORT_RUN}",
                by_name[RUN_REFERENCE]["vs_fmpy"],
                OUTSIDE_LOOP_TARGET,
            )
        )
    targets.append(
        {
            "target": f"  beside: fmionnx run (default) / {IMPORT_FMU}",
            "value": by_name[RUN_DEFAULT]["median_s"] / by_name[IMPORT_FMU]["median_s"],
            "limit": None,
            "met": None,
        }
    )
    results["targets"] = targets
    report.print_table(console, "Targets (reported, not asserted)", report.TARGET_COLUMNS, targets)
    return results


#: The tables against an import: the ratio column is to the import's median.
IMPORT_COLUMNS = (
    ("contender", "command"),
    ("median_s", "wall s (median; a run: outside its loop)"),
    ("min_s", "wall s (min)"),
    ("loop_s", "loop s (median)"),
    ("vs_fmpy", "x the import"),
    ("cpu_s", "CPU s (median)"),
    ("cpu_vs_fmpy", "x the import (CPU)"),
    ("runs", "runs"),
)


def _target(name: str, value: float | None, limit: float) -> dict[str, Any]:
    return {
        "target": name,
        "value": value,
        "limit": f"<= {limit:g}",
        "met": None if value is None else value <= limit,
    }


if __name__ == "__main__":
    main()
