"""Run every example the way its README tells a user to, and say which ones work (``make examples``).

Why a runner: an example that is not run rots. Each example below is the list of commands its
README shows, run from the repository root with this interpreter's ``fmionnx``; the runner
refuses a command the README does not show (so the two cannot drift apart), fails an example
when a command exits non-zero (``fmionnx run`` exits 1 when a check of the system fails), and
then checks the results itself where a system cannot state its own checks (an SSP from another
tool, a shortened ROS 2 run). One line per example: name, pass/fail, wall time; exit 1 when one
failed, with the tail of the failing command's output.

What the READMEs show from the results cannot drift either. Their tables (the checks of a run,
the cases of a study, a command's output) are blocks between ``<!-- make examples: NAME -->``
and ``<!-- end make examples -->``, generated from the run: a block that differs from what the
run gives fails the example. Their pictures (small PNGs, committed on purpose: see
docs/decisions.md) are compared by the data they are drawn from, not by their pixels (a
matplotlib or font update changes pixels, not what a plot says): ``pictures.json`` beside the
README keeps, per picture, that data (titles, labels, the values drawn, sampled) and the
sha256 of the committed PNG drawn from it; a run whose data differs beyond
:data:`RELATIVE_TOLERANCE` fails the example, and ``tests/examples`` checks that each committed
PNG is the one ``pictures.json`` describes.

``--refresh`` rewrites the generated blocks, the pictures and ``pictures.json`` from a passing
run (``--pictures`` is its old name).

Usage: ``python examples/run_all.py [--only NAME ...] [--refresh] [--list]``.
"""

from __future__ import annotations

import argparse
import csv
import filecmp
import hashlib
import json
import math
import os
import random
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent
REPO = EXAMPLES.parent
BUILD = Path("build/examples")
#: A documentation picture larger than this is refused: they live in git.
PICTURE_LIMIT = 100_000
STEP_TIMEOUT = 300.0
TAIL_LINES = 30
#: Beside each README: per picture, the data it is drawn from and the PNG's sha256.
MANIFEST = "pictures.json"
#: Values a picture draws are sampled at this many evenly spaced rows.
SAMPLES = 25
#: Drawn values agree within this relative difference (or ABSOLUTE_TOLERANCE near zero):
#: far below what a picture shows, far above rounding noise between machines.
RELATIVE_TOLERANCE = 1e-3
ABSOLUTE_TOLERANCE = 1e-9
#: A README block generated from the results, and its end.
BLOCK = re.compile(
    r"(?P<head><!-- make examples: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(?P<tail><!-- end make examples -->)",
    re.DOTALL,
)
REFRESH_HINT = "`python examples/run_all.py --refresh --only {name}` writes what this run gave"


@dataclass(frozen=True)
class Step:
    """One command of a README, as a user types it from the repository root."""

    command: str
    #: Started and left running; the runner waits for it after the last foreground command.
    background: bool = False


@dataclass(frozen=True)
class Picture:
    """A documentation picture: how to make it from a run, and the data it is drawn from."""

    make: Callable[[Path], None]
    #: What the picture shows, as JSON values (numbers compared within the tolerance).
    data: Callable[[], object]


@dataclass(frozen=True)
class Example:
    """An example folder: the commands its README shows, and what must hold afterwards."""

    name: str
    steps: tuple[Step, ...]
    #: Problems found in the results (empty: fine); runs after every command succeeded.
    verify: Callable[[], list[str]] = list
    #: Documentation pictures: destination file name in the example folder -> its picture.
    pictures: dict[str, Picture] = field(default_factory=dict)
    #: README blocks generated from the results: block name -> its text (Markdown).
    blocks: dict[str, Callable[[], str]] = field(default_factory=dict)
    #: Extra environment of every command.
    env: dict[str, str] = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        """The example's folder, which holds its README."""
        return EXAMPLES / self.name

    @property
    def out(self) -> Path:
        """Where its commands write (below build/, never in git)."""
        return BUILD / self.name


class ExampleError(Exception):
    """An example did not do what its README says; the message says what and shows output."""


# -- reading results ----------------------------------------------------------------------------


def _columns(path: Path) -> dict[str, list[float]]:
    """``results.csv`` as columns of floats."""
    with path.open(encoding="utf-8", newline="") as stream:
        rows = list(csv.reader(stream))
    header, values = rows[0], rows[1:]
    return {name: [float(row[i]) for row in values] for i, name in enumerate(header)}


def _checks_passed(run_json: Path, expected: int) -> list[str]:
    """Problems unless ``run.json`` records ``expected`` checks, every one passed."""
    record = json.loads(run_json.read_text(encoding="utf-8"))
    checks = record.get("checks") or []
    problems = [f"check failed: {c['name']}" for c in checks if not c.get("passed")]
    if len(checks) != expected:
        problems.append(
            f"{run_json}: {len(checks)} checks evaluated, the example expects {expected}"
        )
    return problems


def _copy_plot(run_dir: Path, *, containing: str) -> Callable[[Path], None]:
    """A picture maker copying the plot of ``run_dir`` whose name contains ``containing``.

    The plot is looked up in the files ``run.json`` lists rather than by an exact name, since
    plot file names derived from titles may change; systems written for the examples name
    their plot files (``file:``) and are found by that name.
    """

    def make(destination: Path) -> None:
        record = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
        names = [
            n for n in record.get("files", []) if n.endswith(".png") and containing in n.lower()
        ]
        if not names:
            msg = f"no plot with `{containing}` in its name among {record.get('files')}"
            raise ExampleError(msg)
        shutil.copyfile(run_dir / sorted(names)[0], destination)

    return make


# -- what pictures and tables show -------------------------------------------------------------


def sample(values: list[float], count: int = SAMPLES) -> list[float]:
    """``count`` values at evenly spaced rows, first and last included."""
    if len(values) <= count:
        return list(values)
    return [values[round(i * (len(values) - 1) / (count - 1))] for i in range(count)]


def _plot_data(
    system: str, run_dir: Path, file: str, *, values: bool = True
) -> Callable[[], object]:
    """What the plot ``file`` of ``system`` draws from the run in ``run_dir``: its title, the
    signals with their units, the legend of its map, its marks and, with ``values``, every
    drawn column sampled (a free run, which differs from run to run, keeps the rest)."""

    def data() -> object:
        import fmionnx

        compiled = fmionnx.load(REPO / system).compiled
        (plot,) = [p for p in compiled.plots if p.file == file]
        drawn: dict[str, object] = {
            "title": plot.title,
            "signals": [s.label for s in plot.series],
        }
        if plot.scene is not None:
            drawn["legend"] = sorted({s.label for s in plot.scene.shapes if s.label})
            drawn["sites"] = [s.name for s in plot.scene.sites]
        columns = [c for s in plot.series for c in s.columns]
        if plot.marks is not None:
            drawn["marks"] = [label for _, label in plot.marks.labels]
            columns.append(plot.marks.column)
        if values:
            table = _columns(run_dir / "results.csv")
            drawn["time"] = sample(table["time"])
            drawn["values"] = {c: sample(table[c]) for c in columns}
        return drawn

    return data


def _cases(out: Path) -> list[dict[str, str]]:
    with (out / "cases.csv").open(encoding="utf-8", newline="") as stream:
        return list(csv.DictReader(stream))


def _number(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def _cases_data(out: Path, columns: tuple[str, ...]) -> Callable[[], object]:
    """The study's table behind a plot: ``columns`` of every case (numbers as numbers)."""

    def data() -> object:
        return [{c: _number(row[c]) for c in ("case", *columns)} for row in _cases(out)]

    return data


def differences(recorded: object, fresh: object, where: str = "") -> list[str]:
    """Where ``fresh`` differs from ``recorded``: structure exactly, numbers within the
    tolerance (a NaN equals a NaN)."""
    if isinstance(recorded, dict) and isinstance(fresh, dict):
        if recorded.keys() != fresh.keys():
            return [f"{where or 'top'}: keys {sorted(recorded)} became {sorted(fresh)}"]
        return [d for k in recorded for d in differences(recorded[k], fresh[k], f"{where}.{k}")]
    if isinstance(recorded, list) and isinstance(fresh, list):
        if len(recorded) != len(fresh):
            return [f"{where}: {len(recorded)} items became {len(fresh)}"]
        return [
            d
            for i, (a, b) in enumerate(zip(recorded, fresh, strict=True))
            for d in differences(a, b, f"{where}[{i}]")
        ]
    numbers = (int, float)
    if isinstance(recorded, numbers) and isinstance(fresh, numbers):
        a, b = float(recorded), float(fresh)
        if (math.isnan(a) and math.isnan(b)) or math.isclose(
            a, b, rel_tol=RELATIVE_TOLERANCE, abs_tol=ABSOLUTE_TOLERANCE
        ):
            return []
    elif recorded == fresh:
        return []
    return [f"{where}: {recorded!r} became {fresh!r}"]


def _expected(expression: str) -> str:
    """``< 300`` from ``first_time(...) < 300``: the comparison a check ends with."""
    found = re.search(r"(<=|>=|==|!=|<|>)\s*([^<>=!]+)$", expression)
    return f"{found[1]} {found[2].strip()}" if found else ""


def _checks_block(run_dir: Path) -> Callable[[], str]:
    """The checks of the run in ``run_dir`` as ``fmionnx run`` evaluated them (run.json)."""

    def text() -> str:
        record = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
        rows = [
            f"| {c['name']} | {c['value']:.4g} | {_expected(c['expression'])} | "
            f"{'pass' if c['passed'] else '**fail**'} |"
            for c in record.get("checks") or []
        ]
        return "\n".join(["| check | measured | expected | result |", "|---|---|---|---|", *rows])

    return text


def _log_block(log: Path) -> Callable[[], str]:
    """What a command printed (its log without the command line), as a text block."""

    def text() -> str:
        lines = log.read_text(encoding="utf-8").splitlines()[1:]
        return "\n".join(["```text", *(line.rstrip() for line in lines), "```"])

    return text


def readme_blocks(text: str) -> dict[str, str]:
    """The generated blocks of a README: name -> body (without its markers)."""
    return {m["name"]: m["body"].rstrip("\n") for m in BLOCK.finditer(text)}


def with_blocks(text: str, bodies: dict[str, str]) -> str:
    """``text`` with the generated blocks named in ``bodies`` replaced."""

    def replace(match: re.Match[str]) -> str:
        body = bodies.get(match["name"])
        if body is None:
            return match[0]
        return f"{match['head']}{body}\n{match['tail']}"

    return BLOCK.sub(replace, text)


# -- the examples -------------------------------------------------------------------------------


def robot() -> Example:
    """The reference robot, its system file used where it lives (systems/)."""
    out = BUILD / "robot" / "out"
    system = "systems/sign_follower.yaml"
    return Example(
        name="robot",
        steps=(
            Step(f"fmionnx validate {system}"),
            Step(f"fmionnx run {system} --out {out}"),
        ),
        verify=lambda: _checks_passed(REPO / out / "run.json", 3),
        pictures={
            "trajectory.png": Picture(
                _copy_plot(REPO / out, containing="trajectory"),
                _plot_data(system, REPO / out, "trajectory-a-b.png"),
            ),
            "velocity.png": Picture(
                _copy_plot(REPO / out, containing="velocity"),
                _plot_data(system, REPO / out, "velocity-commands.png"),
            ),
        },
        blocks={"checks": _checks_block(REPO / out)},
    )


def from_scratch() -> Example:
    """Heater and PI controller FMUs from C, a learned ONNX feed-forward, signal stimuli."""
    out = BUILD / "from-scratch" / "out"
    models = BUILD / "from-scratch"
    return Example(
        name="from-scratch",
        steps=(
            Step("python examples/from-scratch/build.py"),
            Step(
                f"fmionnx validate {models}/Heater.fmu {models}/PIController.fmu "
                f"{models}/feedforward.onnx"
            ),
            Step("fmionnx validate examples/from-scratch/heating.yaml"),
            Step(f"fmionnx run examples/from-scratch/heating.yaml --out {out}"),
        ),
        verify=lambda: _checks_passed(REPO / out / "run.json", 6),
        pictures={
            name: Picture(
                _copy_plot(REPO / out, containing=name.removesuffix(".png")),
                _plot_data("examples/from-scratch/heating.yaml", REPO / out, name),
            )
            for name in ("temperatures.png", "power.png")
        },
        blocks={"checks": _checks_block(REPO / out)},
    )


def _roundtrip_results(out: Path) -> list[str]:
    runs = [out / name / "results.csv" for name in ("run-ssp", "run-yaml", "run-exported")]
    problems = [
        f"{run} differs from {runs[0]}"
        for run in runs[1:]
        if not filecmp.cmp(runs[0], run, shallow=False)
    ]
    table = _columns(runs[0])
    final = table["room.T"][-1]
    if abs(final - 21.0) > 0.02 * 21.0:  # the vendor's setpoint, from controller.ssv
        problems.append(f"room.T ends at {final:.3f} degC, not within 2 % of the setpoint 21")
    return problems


#: The three runs of the SSP round trip, as the picture labels them.
ROUNDTRIP_RUNS = {
    "run-ssp": "heating.ssp (as the other tool wrote it)",
    "run-yaml": "heating.yaml (fmionnx convert)",
    "run-exported": "heating_fmionnx.ssp (fmionnx export)",
}


def _roundtrip_data(out: Path) -> Callable[[], object]:
    """The room temperature of each run, sampled, under its label."""

    def data() -> object:
        return {
            label: sample(_columns(out / folder / "results.csv")["room.T"])
            for folder, label in ROUNDTRIP_RUNS.items()
        }

    return data


def _roundtrip_picture(out: Path) -> Callable[[Path], None]:
    """The three runs' room temperature in one plot: they lie on top of each other."""

    def make(destination: Path) -> None:
        import matplotlib as mpl

        mpl.use("Agg")
        import matplotlib.pyplot as plt

        figure, axes = plt.subplots(figsize=(8, 4))
        styles = {"run-ssp": ("-", 4.0), "run-yaml": ("--", 2.5), "run-exported": (":", 2.0)}
        for folder, (style, width) in styles.items():
            table = _columns(out / folder / "results.csv")
            label = ROUNDTRIP_RUNS[folder]
            axes.plot(table["time"], table["room.T"], style, lw=width, label=label)
        axes.axhline(21.0, color="grey", lw=0.8)
        axes.set_xlabel("time [s]")
        axes.set_ylabel("room.T [degC]")
        axes.set_title("One system, three files, identical results")
        axes.grid(visible=True, alpha=0.3)
        axes.legend(loc="lower right")
        figure.tight_layout()
        figure.savefig(destination, dpi=90)
        plt.close(figure)

    return make


def ssp_roundtrip() -> Example:
    """An OMSimulator-style SSP: imported, run, converted to YAML, exported back, run again."""
    out = BUILD / "ssp-roundtrip"
    return Example(
        name="ssp-roundtrip",
        steps=(
            Step("python examples/ssp-roundtrip/pack.py"),
            Step(f"fmionnx validate {out}/heating.ssp"),
            Step(f"fmionnx run {out}/heating.ssp --out {out}/run-ssp"),
            Step(f"fmionnx convert {out}/heating.ssp -o {out}/heating.yaml"),
            Step(f"fmionnx run {out}/heating.yaml --out {out}/run-yaml"),
            Step(f"fmionnx export {out}/heating.yaml -o {out}/heating_fmionnx.ssp"),
            Step(f"fmionnx run {out}/heating_fmionnx.ssp --out {out}/run-exported"),
            Step(f"python examples/ssp-roundtrip/read_with_fmpy.py {out}/heating_fmionnx.ssp"),
            Step(f"cmp {out}/run-ssp/results.csv {out}/run-exported/results.csv"),
        ),
        verify=lambda: _roundtrip_results(REPO / out),
        pictures={
            "roundtrip.png": Picture(_roundtrip_picture(REPO / out), _roundtrip_data(REPO / out))
        },
        # what `fmionnx validate` says about the archive (step 2)
        blocks={"validate": _log_block(REPO / out / "logs" / "2.log")},
    )


def _external_results(out: Path) -> list[str]:
    record = json.loads((out / "run.json").read_text(encoding="utf-8"))
    problems = []
    if record.get("backend") != "ros2" or record.get("status") != "completed":
        problems.append(f"run.json: backend {record.get('backend')}, status {record.get('status')}")
    if (record.get("execution") or {}).get("external") != "world":
        problems.append("run.json: the world is not recorded as external")
    table = _columns(out / "results.csv")
    # The in-process reference reaches x = 3.02 m at the first (blue) sign by 8 s and turns left.
    if table["odometry.posX"][-1] < 2.5:
        problems.append(
            f"the robot drove to x = {table['odometry.posX'][-1]:.2f} m, not past 2.5 m"
        )
    if max(table["detector.blobSize[0,2]"]) < 100:
        problems.append("the detector never saw the blue board in the outside camera images")
    if max(table["tracker.w"]) < 0.5:
        problems.append("the tracker never turned left at the blue board")
    return problems


def external_simulator() -> Example:
    """The robot's software as ROS 2 nodes against a simulator started as its own process."""
    out = BUILD / "external-simulator"
    system = "examples/external-simulator/sign_follower_external.yaml"
    return Example(
        name="external-simulator",
        steps=(
            Step(f"fmionnx validate {system}"),
            Step(f"fmionnx ros2 launch-file {system} -o {out}/sign_follower_external.launch.py"),
            Step(
                "fmionnx node systems/sign_follower.yaml world --sync free --stop-time 12",
                background=True,
            ),
            Step(
                f"fmionnx run {system} --backend ros2 --sync free --stop-time 12 --no-checks "
                f"--out {out}/out"
            ),
        ),
        verify=lambda: _external_results(REPO / out / "out"),
        pictures={
            # a free run differs by millimetres from run to run: its values are not compared
            # (the verification above checks them), what the picture shows is
            "trajectory.png": Picture(
                _copy_plot(REPO / out / "out", containing="trajectory"),
                _plot_data(system, REPO / out / "out", "trajectory.png", values=False),
            )
        },
        # A domain of its own and loopback only: parallel runs on this host never meet.
        env={
            "ROS_DOMAIN_ID": str(random.SystemRandom().randint(1, 99)),
            "ROS_LOCALHOST_ONLY": "1",
        },
    )


def _sweep_results(out: Path) -> list[str]:
    """Every case of the study ran (a failed check is a result; a failed case is not)."""
    with (out / "cases.csv").open(encoding="utf-8", newline="") as stream:
        rows = list(csv.DictReader(stream))
    problems = [f"{r['case']}: {r['status']} ({r['message']})" for r in rows if r["status"] != "ok"]
    if len(rows) != 4:
        problems.append(f"{out / 'cases.csv'}: {len(rows)} cases, the study has 4")
    problems.extend(
        f"{out / name} is missing"
        for name in ("cases.parquet", "heatmap-time_to_B.png", "passfail.png")
        if not (out / name).is_file()
    )
    return problems


def _copy_file(source: Path) -> Callable[[Path], None]:
    def make(destination: Path) -> None:
        shutil.copyfile(source, destination)

    return make


#: The study's targets and its system's checks, as cases.csv names them.
SWEEP_TARGETS = ("tracker.cruiseSpeed", "tracker.turnRate")
SWEEP_CHECKS = ("check: reaches B", "check: stops", "check: stays on the path")


def _cases_block(out: Path) -> Callable[[], str]:
    """The study's table, one row per case, as the README shows it."""

    def text() -> str:
        def verdict(value: str) -> str:
            return "yes" if value == "True" else "**no**"

        rows = [
            f"| {r['case']} | {float(r[SWEEP_TARGETS[0]]):g} | {float(r[SWEEP_TARGETS[1]]):g} | "
            f"{float(r['distance_to_B']):.3f} m | {float(r['time_to_B']):.2f} s | "
            f"{float(r['max_deviation']):.3f} m | "
            + " | ".join(verdict(r[c]) for c in SWEEP_CHECKS)
            + " |"
            for r in _cases(out)
        ]
        head = (
            "| case | cruiseSpeed | turnRate | distance to B | time to B | max deviation | "
            "reaches B | stops | stays on the path |"
        )
        return "\n".join([head, "|---|---|---|---|---|---|---|---|---|", *rows])

    return text


def sweep_tracker() -> Example:
    """A study over the tracker's gains on the reference scenario, on a local Dask cluster."""
    out = BUILD / "sweep-tracker" / "out"
    return Example(
        name="sweep-tracker",
        steps=(Step(f"fmionnx sweep examples/sweep-tracker/study.yaml --out {out} --force"),),
        verify=lambda: _sweep_results(REPO / out),
        pictures={
            "heatmap.png": Picture(
                _copy_file(REPO / out / "heatmap-time_to_B.png"),
                _cases_data(REPO / out, (*SWEEP_TARGETS, "time_to_B", "status")),
            ),
            "passfail.png": Picture(
                _copy_file(REPO / out / "passfail.png"),
                _cases_data(REPO / out, (*SWEEP_TARGETS, *SWEEP_CHECKS, "status")),
            ),
        },
        blocks={"cases": _cases_block(REPO / out)},
    )


ALL: tuple[Callable[[], Example], ...] = (
    robot,
    from_scratch,
    ssp_roundtrip,
    external_simulator,
    sweep_tracker,
)


# -- running ------------------------------------------------------------------------------------


def argv_of(command: str) -> list[str]:
    """The process to start for a README command: ``fmionnx``/``python`` are this venv's."""
    words = shlex.split(command)
    if words[0] == "fmionnx":
        return [sys.executable, "-m", "fmionnx", *words[1:]]
    if words[0] == "python":
        return [sys.executable, *words[1:]]
    return words


def readme_problems(example: Example) -> list[str]:
    """Commands the runner runs that the example's README does not show (verbatim)."""
    readme = example.folder / "README.md"
    if not readme.is_file():
        return [f"{readme} is missing"]
    text = readme.read_text(encoding="utf-8")
    return [f"{readme} does not show `{s.command}`" for s in example.steps if s.command not in text]


def _tail(log: Path) -> str:
    lines = log.read_text(encoding="utf-8", errors="replace").splitlines()
    return "\n".join(f"    {line}" for line in lines[-TAIL_LINES:])


def _stop(process: subprocess.Popen[bytes]) -> None:
    """End a background command we started (its own process group) and reap it."""
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def run_example(example: Example, *, refresh: bool) -> None:
    """Run every step; raise ExampleError with what went wrong.

    Then compare the README's generated blocks and the pictures' data with this run's
    (``refresh``: write them instead).
    """
    problems = readme_problems(example)
    if problems:
        raise ExampleError("\n".join(problems))
    logs = REPO / example.out / "logs"
    shutil.rmtree(logs, ignore_errors=True)
    logs.mkdir(parents=True)
    env = {**os.environ, **example.env}
    background: list[tuple[Step, subprocess.Popen[bytes], Path]] = []
    try:
        for index, step in enumerate(example.steps, 1):
            log = logs / f"{index}.log"
            with log.open("wb") as stream:
                stream.write(f"$ {step.command}\n".encode())
                stream.flush()
                process = subprocess.Popen(
                    argv_of(step.command),
                    cwd=REPO,
                    env=env,
                    stdin=subprocess.DEVNULL,
                    stdout=stream,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,  # its own group: stopped as a whole on failure
                )
            if step.background:
                background.append((step, process, log))
                continue
            try:
                code = process.wait(timeout=STEP_TIMEOUT)
            except subprocess.TimeoutExpired:
                _stop(process)
                msg = f"`{step.command}` took more than {STEP_TIMEOUT:g} s:\n{_tail(log)}"
                raise ExampleError(msg) from None
            if code != 0:
                raise ExampleError(f"`{step.command}` exited {code}:\n{_tail(log)}")
        for step, process, log in background:
            try:
                code = process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                msg = f"`{step.command}` did not end after the run:\n{_tail(log)}"
                raise ExampleError(msg) from None
            if code != 0:
                raise ExampleError(f"`{step.command}` exited {code}:\n{_tail(log)}")
    finally:
        for _, process, _ in background:
            _stop(process)
    problems = example.verify()
    if problems:
        raise ExampleError("\n".join(problems))
    problems = [
        *_compare_blocks(example, refresh=refresh),
        *_compare_pictures(example, refresh=refresh),
    ]
    if problems:
        problems.append(REFRESH_HINT.format(name=example.name))
        raise ExampleError("\n".join(problems))


def _compare_blocks(example: Example, *, refresh: bool) -> list[str]:
    """Problems where the README's generated blocks differ from this run's (or rewrite them)."""
    if not example.blocks:
        return []
    readme = example.folder / "README.md"
    text = readme.read_text(encoding="utf-8")
    shown = readme_blocks(text)
    fresh = {name: make() for name, make in example.blocks.items()}
    missing = [
        f"{readme} has no block `{n}` (`<!-- make examples: {n} -->`)"
        for n in fresh
        if n not in shown
    ]
    if missing:
        return missing
    if refresh:
        readme.write_text(with_blocks(text, fresh), encoding="utf-8")
        return []
    return [
        f"{readme}: block `{name}` differs from this run:\n--- README ---\n{shown[name]}"
        f"\n--- this run ---\n{body}"
        for name, body in fresh.items()
        if shown[name] != body
    ]


def read_manifest(example: Example) -> dict[str, dict[str, object]]:
    """``pictures.json`` of an example: picture name -> {sha256, data} (empty when absent)."""
    path = example.folder / MANIFEST
    if not path.is_file():
        return {}
    loaded: dict[str, dict[str, object]] = json.loads(path.read_text(encoding="utf-8"))
    return loaded


def _compare_pictures(example: Example, *, refresh: bool) -> list[str]:
    """Problems where a picture's data differs from the recorded one (or redraw them all)."""
    if not example.pictures:
        return []
    manifest = read_manifest(example)
    fresh = {name: picture.data() for name, picture in example.pictures.items()}
    if refresh:
        for name, picture in example.pictures.items():
            destination = example.folder / name
            picture.make(destination)
            size = destination.stat().st_size
            if size > PICTURE_LIMIT:
                return [f"{destination} is {size} bytes, over the {PICTURE_LIMIT} of a picture"]
            digest = hashlib.sha256(destination.read_bytes()).hexdigest()
            manifest[name] = {"sha256": digest, "data": fresh[name]}
        manifest = {name: manifest[name] for name in sorted(example.pictures)}
        text = json.dumps(manifest, indent=1, allow_nan=True) + "\n"
        (example.folder / MANIFEST).write_text(text, encoding="utf-8")
        return []
    problems = []
    for name, data in fresh.items():
        recorded = manifest.get(name)
        if recorded is None:
            problems.append(f"{example.folder / MANIFEST} records nothing for `{name}`")
            continue
        found = differences(recorded.get("data"), json.loads(json.dumps(data)))
        if found:
            shown = "\n  ".join(found[:10]) + ("\n  ..." if len(found) > 10 else "")
            problems.append(f"`{name}` draws other data than the committed picture:\n  {shown}")
    return problems


def main(argv: list[str] | None = None) -> int:
    """Command line; exit 1 when an example failed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run these examples only")
    parser.add_argument(
        "--refresh",
        "--pictures",
        action="store_true",
        help="rewrite the READMEs' generated blocks, the pictures and pictures.json",
    )
    parser.add_argument("--list", action="store_true", help="print the examples' names and exit")
    args = parser.parse_args(argv)
    examples = [make() for make in ALL]
    if args.list:
        print("\n".join(e.name for e in examples))
        return 0
    if args.only:
        unknown = set(args.only) - {e.name for e in examples}
        if unknown:
            parser.error(f"no example {', '.join(sorted(unknown))}; see --list")
        examples = [e for e in examples if e.name in args.only]
    width = max(len(e.name) for e in examples)
    failed = 0
    started = time.perf_counter()
    for example in examples:
        began = time.perf_counter()
        try:
            run_example(example, refresh=args.refresh)
        except ExampleError as exc:
            failed += 1
            print(
                f"{example.name:<{width}}  FAIL  {time.perf_counter() - began:6.1f} s", flush=True
            )
            print(f"  {exc}", flush=True)
        else:
            print(
                f"{example.name:<{width}}  pass  {time.perf_counter() - began:6.1f} s", flush=True
            )
    total = time.perf_counter() - started
    print(f"{len(examples) - failed} of {len(examples)} examples passed in {total:.1f} s")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
