"""The native kernel's reach: chains of FMI 2 and FMI 3 FMUs of several port types, stepped by
the native kernel and by the Python path (``FMIONNX_NATIVE=0``), side by side in one run.

Each row is a chain of N copies of one test FMU (built from ``tests/fixtures/fmus``),
connected output to input, run by the in-process master with nothing recorded; the time is
the master's ``RunResult.wall_time`` (the stepping loop only), the median of interleaved
repetitions (the two paths alternate which goes first, so drifting load hits both alike).

* ``FMI 2, float64 (Gain)``: the chain of :mod:`benchmarks.chain` (one ``fmi2SetReal``,
  ``fmi2DoStep``, ``fmi2GetReal`` per FMU-step);
* ``FMI 3, float64 (Scale3)``: the same with ``fmi3SetFloat64``/``fmi3DoStep``/``fmi3GetFloat64``;
* ``FMI 3, float32 (Types3)``: ``Types3`` (one input and one output of each of the 11 numeric
  FMI 3 types, so 11 set and 12 get calls per FMU-step on either path) connected
  ``y_f32 -> u_f32``;
* ``FMI 3, 11 types (Types3)``: the same FMU with all eleven ``y_T -> u_T`` connected.

Before timing, each chain runs once both ways recording the tail's outputs, which must be
bit-identical (column "same results"). Run: ``python benchmarks/native_reach.py`` (well under
a minute on 2 cores), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

from rich.console import Console  # noqa: E402

from benchmarks import machine, report  # noqa: E402
from benchmarks.chain import native_kernel  # noqa: E402

FIXTURES = REPO / "tests" / "fixtures" / "fmus"
TYPES = ("f64", "f32", "i8", "u8", "i16", "u16", "i32", "u32", "i64", "u64", "bool")

NATIVE = "native"
PYTHON = "Python path"


@dataclass(frozen=True)
class Case:
    """One row: an FMU of the fixtures, the ports each link connects, what the tail records."""

    label: str
    fixture: str
    links: tuple[tuple[str, str], ...]
    record: tuple[str, ...]
    head: str = ""


CASES = (
    Case("FMI 2, float64 (Gain)", "Gain", (("y", "u"),), ("y",), "{u: 1.0}"),
    Case("FMI 3, float64 (Scale3)", "Scale3", (("y", "u"),), ("y",), "{u: 1.0}"),
    Case("FMI 3, float32 (Types3)", "Types3", (("y_f32", "u_f32"),), ("y_f32",)),
    Case(
        "FMI 3, 11 types (Types3)",
        "Types3",
        tuple((f"y_{t}", f"u_{t}") for t in TYPES),
        tuple(f"y_{t}" for t in TYPES),
    ),
)

COLUMNS = (
    ("case", "chain"),
    ("native_us", "native µs/step"),
    ("python_us", "Python path µs/step"),
    ("native_fmu_us", "native µs per FMU-step"),
    ("python_fmu_us", "Python µs per FMU-step"),
    ("speedup", "Python / native"),
    ("native_groups", "native groups"),
    ("identical", "same results"),
)


def system_text(case: Case, fmu: Path, n: int, steps: int, step: float = 1e-3) -> str:
    """The chain as a system file (the FMU path is absolute: the file lives in a temp dir)."""
    lines = [
        "fmionnx: 1",
        f"name: reach_{case.fixture.lower()}_{n}",
        f"run: {{start: 0, stop: {steps * step!r}, step: {step!r}}}",
        "components:",
    ]
    for i in range(n):
        head = f", parameters: {case.head}" if i == 0 and case.head else ""
        lines.append(f"  m{i}: {{kind: fmu, path: '{fmu.as_posix()}'{head}}}")
    lines.append("connections:" if n > 1 else "connections: []")
    lines.extend(f"  - m{i - 1}.{y} -> m{i}.{u}" for i in range(1, n) for y, u in case.links)
    return "\n".join(lines) + "\n"


def measure(case: Case, fmu: Path, n: int, steps: int, repeat: int) -> dict[str, Any]:
    """One row: median loop times of both paths, and whether they computed the same."""
    import fmionnx
    from fmionnx.core.types import PortRef
    from fmionnx.runtime.result import RunOptions, RunStatus

    folder = Path(tempfile.mkdtemp(prefix="fmionnx-reach-"))
    try:
        path = folder / "chain.yaml"
        path.write_text(system_text(case, fmu, n, steps), encoding="utf-8")
        system = fmionnx.load(path)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    tail = tuple(PortRef(f"m{n - 1}", port) for port in case.record)
    checks = {}
    for native in (True, False):
        with native_kernel(native):
            checks[native] = system.run(
                stop_time=min(steps, 200) * 1e-3, signals=tail, isolate="none"
            )
    identical = all(
        checks[True].signals[name].tobytes() == values.tobytes()
        for name, values in checks[False].signals.items()
    ) and list(checks[True].signals) == list(checks[False].signals)
    silent = RunOptions(record=())
    times: dict[bool, list[float]] = {True: [], False: []}
    groups = 0
    for r in range(repeat):
        for native in (True, False) if r % 2 == 0 else (False, True):
            with native_kernel(native):
                result = system.run(options=silent)
            if result.status is not RunStatus.COMPLETED:
                msg = f"{case.label}: run ended {result.status}: {result.error}"
                raise RuntimeError(msg)
            if native:
                groups = int(result.details.get("native_groups") or 0)
            times[native].append(result.wall_time / result.steps_done)
    native_us = statistics.median(times[True]) * 1e6
    python_us = statistics.median(times[False]) * 1e6
    return {
        "case": case.label,
        "n": n,
        "steps": steps,
        "native_us": native_us,
        "python_us": python_us,
        "native_fmu_us": native_us / n,
        "python_fmu_us": python_us / n,
        "speedup": python_us / native_us,
        "native_groups": groups,
        "native_components": int(checks[True].details.get("native_components") or 0),
        "identical": identical,
    }


def build_fixtures(folder: Path, names: Sequence[str]) -> dict[str, Path]:
    """Build each named fixture FMU from C into ``folder``."""
    from fmionnx.kinds.fmu.build import build_fmu

    built = {}
    for name in dict.fromkeys(names):
        built[name] = folder / f"{name}.fmu"
        build_fmu(FIXTURES / name, built[name])
    return built


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Options (defaults are what ``make bench`` runs)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--n", type=int, default=10, help="FMUs per chain")
    parser.add_argument("--steps", type=int, default=5_000, help="steps per run")
    parser.add_argument("--repeat", type=int, default=5, help="interleaved repetitions")
    parser.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run")
    args = parser.parse_args(argv)
    if args.quick:
        args.n, args.steps, args.repeat = 3, 200, 2
    return args


def main(argv: Sequence[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure and print the table; returns the rows (what the table shows)."""
    args = parse(argv)
    console = console or Console(width=None if sys.stdout.isatty() else 150)
    info = machine.describe()
    console.print(machine.headline("fmionnx native kernel reach", info))
    folder = Path(tempfile.mkdtemp(prefix="fmionnx-reach-fmus-"))
    try:
        fmus = build_fixtures(folder, [case.fixture for case in CASES])
        rows = [
            measure(case, fmus[case.fixture], args.n, args.steps, args.repeat) for case in CASES
        ]
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    report.print_table(
        console,
        f"Chains of {args.n} FMUs, {args.steps} steps, nothing recorded, "
        f"median of {args.repeat} interleaved repetitions",
        COLUMNS,
        rows,
    )
    return {"rows": rows}


if __name__ == "__main__":
    main()
