"""``fmionnx run``: run a system in-process or as ROS 2 nodes (or one FMU / ONNX model in-process)
and write its results."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from fmionnx.cli.app import ExitCode, app, fail
from fmionnx.cli.outputs import check_output_file, check_output_folder
from fmionnx.cli.run_safety import CHECKPOINT_EVERY, RunSafety
from fmionnx.core.steps import MAX_RUN_STEPS


def parse_pairs(items: list[str], option: str) -> dict[str, str]:
    """``name=value`` options (``--param``, ``--input``) as a dict; a usage error otherwise."""
    pairs = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise fail(f"{option} `{item}` must look like `name=value`")
        pairs[key.strip()] = value.strip()
    return pairs


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx run systems/sign_follower.yaml            # results in out/sign_follower/\n\n"
    "  fmionnx run systems/sign_follower.yaml --out out/demo\n\n"
    "  fmionnx run systems/sign_follower.yaml --stop-time 10 --param tracker.turnRate=0.6\n\n"
    "  fmionnx run model.fmu --stop-time 5 --step 0.01 --interface me --out out/model\n\n"
    "  fmionnx run model.fmu -p k=2                      # a single FMU: bare variable names\n\n"
    "  fmionnx run model.fmu --plot                      # and signals.png of its outputs\n\n"
    "  fmionnx run detector.onnx --input image=frame.npy --out out/detector\n\n"
    "  fmionnx run systems/sign_follower.yaml --backend ros2 --sync lockstep --out out/ros2",
)
def run(
    target: Annotated[
        Path,
        typer.Argument(
            help="System file (.yaml, .ssp, .ssd, or a compiled .fmionnx.json), or a single "
            "model: .fmu or .onnx."
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Folder for results.csv, run.json and plots (default: out/<system name>/). "
            "Single ONNX model: one .npy per output (default: none).",
        ),
    ] = None,
    no_out: Annotated[
        bool,
        typer.Option(
            "--no-out", help="Write no results at all (e.g. to time or smoke-test a run)."
        ),
    ] = False,
    stop_time: Annotated[
        float | None,
        typer.Option(
            "--stop-time",
            help="Stop time in seconds; replaces the system file's `run.stop` (a single FMU: its "
            "default experiment's stop time).",
        ),
    ] = None,
    param: Annotated[
        list[str] | None,
        typer.Option(
            "--param",
            "-p",
            help="Parameter or start value set before initialization, repeatable; the value is "
            "read as JSON. A system: `component.name=value` (`-p tracker.turnRate=0.6`); a single "
            "FMU: `name=value` (`-p k=2`).",
        ),
    ] = None,
    quiet: Annotated[
        bool,
        typer.Option(
            "--quiet",
            "-q",
            help="No progress bar, warnings or summary; the last line `Results: <folder>` stays.",
        ),
    ] = False,
    record: Annotated[
        Path | None,
        typer.Option(
            "--record",
            help="Also write an MCAP file. In-process: camera frames and the recorded signals; "
            "with --backend ros2: every topic as it crossed the wire.",
        ),
    ] = None,
    step: Annotated[
        float | None,
        typer.Option(
            "--step",
            help="Base (communication) step in seconds; replaces `run.step` and is checked like "
            "it (default: the system file's, else the fastest period, else the models' default "
            "experiment step).",
        ),
    ] = None,
    start_time: Annotated[
        float | None,
        typer.Option(
            "--start-time",
            help="Start time in seconds; replaces `run.start` (a single FMU: 0).",
        ),
    ] = None,
    output_interval: Annotated[
        float | None,
        typer.Option(
            "--output-interval",
            help="Seconds between two rows of results.csv, a whole multiple of the step; "
            "replaces `run.output_interval` (default: every step). The last point is always "
            "written.",
        ),
    ] = None,
    interface: Annotated[
        str | None,
        typer.Option(
            "--interface",
            help="Single FMU only: `cs` (co-simulation) or `me` (model exchange); default: "
            "co-simulation when the FMU offers it.",
        ),
    ] = None,
    inputs: Annotated[
        list[str] | None,
        typer.Option(
            "--input", "-i", help="Single ONNX model only: `name=file.npy` per input, repeatable."
        ),
    ] = None,
    backend: Annotated[
        str,
        typer.Option(
            "--backend",
            help="`inprocess`: one deterministic process. `ros2`: one ROS 2 node process per "
            "component, from the same system file (system files only).",
        ),
    ] = "inprocess",
    sync: Annotated[
        str,
        typer.Option(
            "--sync", help="With --backend ros2: `lockstep` (reproducible) or `free` (paced)."
        ),
    ] = "lockstep",
    ros_distro: Annotated[
        str | None,
        typer.Option(
            "--ros-distro",
            help="With --backend ros2: humble, iron, jazzy or kilted (wire types); replaces the "
            "system file's `ros2: distro:` (default: that, else jazzy).",
        ),
    ] = None,
    middleware: Annotated[
        str,
        typer.Option(
            "--middleware",
            help="With --backend ros2: `dds` (Cyclone DDS), `rclpy` (ROS 2's own) or `zenoh` "
            "(the rmw_zenoh wire).",
        ),
    ] = "dds",
    zenoh_router: Annotated[
        str,
        typer.Option(
            "--zenoh-router",
            help="With --middleware zenoh: `auto` (the configured router, tcp/localhost:7447 "
            "by default, when it answers; else one started for the run) or an endpoint such as "
            "`tcp/10.0.0.2:7447`.",
        ),
    ] = "auto",
    rtf: Annotated[
        float,
        typer.Option(
            "--rtf", help="With --backend ros2 --sync free: simulator pace (x real time; 0: fast)."
        ),
    ] = 1.0,
    input_wait: Annotated[
        float | None,
        typer.Option(
            "--input-wait",
            help="With --backend ros2 --sync free: seconds a node's step waits for an input "
            "sample of its time before stepping on an older one (default 0.1).",
        ),
    ] = None,
    step_timeout: Annotated[
        float,
        typer.Option(
            "--step-timeout",
            help="Seconds one step of a component may take before the run stops with a fault "
            "(in-process and ROS 2 lockstep).",
        ),
    ] = 60.0,
    isolate: Annotated[
        list[str] | None,
        typer.Option(
            "--isolate",
            help="In-process: components whose models run in a process of their own, so a "
            "crash or hang cannot take the run down: `fmus` (every FMU), `all`, `none`, or "
            "component names (repeat the option or separate by commas); `guardian`: the whole "
            "run in one guarded process instead. Default: `guardian` for a lone FMU (on Linux, "
            "without --sandbox or --record), else `fmus` (docs/running.md).",
        ),
    ] = None,
    sandbox: Annotated[
        bool,
        typer.Option(
            "--sandbox",
            help="In-process: confine isolated models (no network, nothing writable but their "
            "own folder; Linux Landlock and namespaces).",
        ),
    ] = False,
    schedule: Annotated[
        str | None,
        typer.Option(
            "--schedule",
            help="In-process: `parallel` (default) runs steps that may overlap others (ONNX "
            "models, isolated components) on a second core, bit-identical to `sequential`, "
            "which runs every step on one thread.",
        ),
    ] = None,
    checkpoint_every: Annotated[
        float,
        typer.Option(
            "--checkpoint-every",
            help="With --out: rewrite results.csv and run.json (status `running`) at least "
            "this many seconds apart while the run goes on, so a killed run keeps its results.",
        ),
    ] = CHECKPOINT_EVERY,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            help="Write into a results folder (--out or the default) that holds files fmionnx "
            "did not write; only the run's own files are replaced.",
        ),
    ] = False,
    checks: Annotated[
        bool,
        typer.Option(
            "--checks/--no-checks",
            help="Evaluate the system's `checks:` after the run: print them, record them in "
            "run.json, exit 1 when one fails (--no-checks: a shortened or exploratory run).",
        ),
    ] = True,
    max_steps: Annotated[
        int,
        typer.Option(
            "--max-steps", help="Refuse runs of more base steps than this (default 10^10)."
        ),
    ] = MAX_RUN_STEPS,
    plot: Annotated[
        bool,
        typer.Option(
            "--plot",
            help="Also draw every recorded signal over time into signals.png in the results "
            "folder (one panel per port, labelled with its unit); any run, a single FMU too.",
        ),
    ] = False,
) -> None:
    """Run a system in-process or as ROS 2 nodes (--backend ros2), or a single FMU / ONNX model.

    Results go to --out, by default out/<system name>/; the last line names the folder. A fault
    or a failed check exits 1 after writing what was recorded; Ctrl-C exits 130, SIGTERM 143.
    """
    suffix = target.suffix.lower()
    if interface is not None and interface not in ("cs", "me"):
        raise fail(f"--interface must be `cs` or `me`, not `{interface}`")
    if interface is not None and suffix != ".fmu":
        raise fail("--interface applies to a single .fmu only")
    if suffix == ".onnx" and (step, start_time, output_interval) != (None, None, None):
        raise fail(
            "--step, --start-time and --output-interval apply to systems and FMUs, not to "
            "a single ONNX model's inference"
        )
    if inputs and suffix != ".onnx":
        raise fail("--input applies to a single .onnx model only")
    if out is not None and no_out:
        raise fail("--out and --no-out exclude each other")
    if plot and (no_out or suffix == ".onnx"):
        raise fail("--plot draws the recorded signals into the results folder: not with "
                   "--no-out or a single ONNX model (one call, no signals over time)")  # fmt: skip
    if out is not None:
        _check_out(out, force=force, system_run=suffix != ".onnx")
    if record is not None:
        check_output_file(record, "--record")
    if max_steps < 1:
        raise fail("--max-steps must be at least 1")
    ros2 = _ros2_options(backend, sync, ros_distro, middleware, rtf, suffix, record, step_timeout)
    if input_wait is not None:
        ros2 = _with_input_wait(ros2, input_wait)
    if ros2 is not None:
        ros2 = _with_zenoh_router(ros2, zenoh_router)
    elif zenoh_router != "auto":
        raise fail("--zenoh-router applies to --backend ros2 --middleware zenoh")
    if ros2 is not None and (isolate or sandbox):
        raise fail("--isolate and --sandbox apply in-process; ROS 2 nodes are processes already")
    if schedule is not None and schedule not in ("parallel", "sequential"):
        raise fail(f"--schedule must be `parallel` or `sequential`, not `{schedule}`")
    if ros2 is not None and schedule is not None:
        raise fail("--schedule applies in-process; ROS 2 nodes are processes already")
    if not step_timeout > 0:
        raise fail("--step-timeout must be > 0 seconds")
    if not checkpoint_every >= 0:
        raise fail("--checkpoint-every must be >= 0 seconds")
    safety = RunSafety(
        isolate=None  # not given: chosen per system (a lone FMU: guardian; see RunSafety)
        if isolate is None
        else [w.strip() for item in isolate for w in item.split(",") if w.strip()],
        sandbox=sandbox,
        step_timeout=step_timeout,
        checkpoint_every=checkpoint_every,
        plot_signals=plot,
        schedule=schedule or "parallel",
    )
    from fmionnx.runtime.stopping import exit_code, stop_on_signals, stop_reason

    try:
        if suffix == ".onnx":
            _run_onnx(target, parse_pairs(inputs or [], "--input"), out, quiet=quiet)
            return
        # SIGTERM/SIGHUP stop like Ctrl-C: the results are written
        with stop_on_signals(process_ends=True):
            code = _run_system(
                target,
                out=out,
                write=not no_out,
                force=force,
                stop_time=stop_time,
                params=parse_pairs(param or [], "--param"),
                quiet=quiet,
                record=record,
                step=step,
                interface=interface,
                ros2=ros2,
                start_time=start_time,
                output_interval=output_interval,
                max_steps=max_steps,
                safety=safety,
                evaluate=checks,
                plot_signals=plot,
            )
    except KeyboardInterrupt as exc:
        reason = stop_reason(exc)
        raise fail(f"interrupted by {reason} before the run started", exit_code(reason)) from None
    raise typer.Exit(code)


def _check_out(out: Path, *, force: bool, system_run: bool, default: bool = False) -> None:
    """``--out`` is usable; a folder of someone else's files is refused unless ``--force``.

    Checked before the run: learning after minutes of simulation that the results would be
    mixed into an unrelated folder is too late. See ``fmionnx.results.outdir``. The default
    folder (``default``) follows the same rules; the message then says where it came from.
    """
    from fmionnx.results.outdir import foreign_folder

    if system_run and not force and foreign_folder(out):
        if default:
            msg = (
                f"the default results folder `{out}` holds files that are not the output of "
                "an earlier fmionnx run; choose a folder with --out, or use --force to write "
                "into it"
            )
        else:
            msg = (
                f"--out `{out}` holds files that are not the output of an earlier fmionnx run; "
                "choose an empty folder or use --force to write into it"
            )
        raise fail(msg)
    check_output_folder(out, "--out" if not default else "the default results folder")


def _ros2_options(
    backend: str,
    sync: str,
    distro: str | None,
    middleware: str,
    rtf: float,
    suffix: str,
    record: Path | None,
    step_timeout: float,
) -> Any:
    """The ROS 2 backend's options, or None for the in-process backend (usage errors exit 2)."""
    if backend not in ("inprocess", "ros2"):
        raise fail(f"--backend must be `inprocess` or `ros2`, not `{backend}`")
    if backend == "inprocess":
        return None
    from fmionnx.backends.ros2.node import SyncMode
    from fmionnx.backends.ros2.supervisor import Ros2Options
    from fmionnx.compile.ros2.messages import RosDistro

    if sync not in {m.value for m in SyncMode}:
        raise fail(f"--sync must be `lockstep` or `free`, not `{sync}`")
    if distro is not None and distro not in {d.value for d in RosDistro}:
        raise fail(f"--ros-distro must be one of {', '.join(d.value for d in RosDistro)}")
    if middleware not in ("dds", "rclpy", "zenoh"):
        raise fail(f"--middleware must be `dds`, `rclpy` or `zenoh`, not `{middleware}`")
    if suffix in (".fmu", ".onnx"):
        raise fail("--backend ros2 runs system files, not a single model")
    if not rtf >= 0:  # also NaN
        raise fail("--rtf must be >= 0 (0: as fast as possible)")
    if not step_timeout > 0:
        raise fail("--step-timeout must be > 0 seconds")
    if middleware == "rclpy":  # checked in a child process: rclpy stays out of this one
        from fmionnx.backends.ros2.rclpy_env import rclpy_problem

        problem = rclpy_problem()
        if problem is not None:
            raise fail(f"--middleware rclpy: {problem}; or use `--middleware dds` (the default)")
    return Ros2Options(
        sync=SyncMode(sync), distro=None if distro is None else RosDistro(distro), rtf=rtf,
        record=record,
        step_timeout=step_timeout, middleware=middleware,
    )  # fmt: skip


def _check_rclpy_distro(compiled: Any, ros2: Any) -> None:
    """``--middleware rclpy``: the run's distribution (``--ros-distro``, else the system
    file's) must be rclpy's; known only once the system is loaded, still before any node."""
    if ros2.middleware != "rclpy":
        return
    from fmionnx.backends.ros2.loading import resolve_distro
    from fmionnx.backends.ros2.rclpy_env import distro_problem

    problem = distro_problem(resolve_distro(compiled, ros2.distro))
    if problem is not None:
        raise fail(f"--middleware rclpy: {problem}; or use `--middleware dds` (the default)")


def _with_input_wait(ros2: Any, seconds: float) -> Any:
    """``--input-wait``: checked, and only with ``--backend ros2 --sync free``."""
    if ros2 is None or ros2.sync.value != "free":
        raise fail("--input-wait applies to --backend ros2 --sync free only")
    if not 0 <= seconds < float("inf"):  # also NaN
        raise fail("--input-wait must be >= 0 seconds")
    return dataclasses.replace(ros2, input_wait=seconds)


def _with_zenoh_router(ros2: Any, spec: str) -> Any:
    """``--zenoh-router`` checked and added to the ROS 2 options (usage errors exit 2)."""
    if ros2.middleware != "zenoh":
        if spec != "auto":
            raise fail("--zenoh-router applies to --middleware zenoh")
        return ros2
    from fmionnx.backends.ros2.zenoh.router import router_problem

    problem = router_problem(spec)
    if problem is not None:
        raise fail(problem)
    return dataclasses.replace(ros2, zenoh_router=spec)


def load_target(target: Path, *, quiet: bool, **kwargs: Any) -> Any:
    """Compile ``target``; its errors rendered like ``validate`` (exit 1), warnings unless quiet."""
    from fmionnx import api
    from fmionnx.core.diagnostics import Severity
    from fmionnx.core.errors import DiagnosticError

    try:
        system = api.load(target, **kwargs)
    except api.OverrideError as exc:  # --step on a compiled system
        raise fail(str(exc)) from None
    except DiagnosticError as exc:
        from fmionnx.reporters import FileResult
        from fmionnx.reporters.text import TextReporter

        TextReporter().render(
            [FileResult(target, tuple(exc.diagnostics))], sys.stderr, color=sys.stderr.isatty()
        )
        raise typer.Exit(ExitCode.PROBLEMS) from None
    warnings = tuple(d for d in system.diagnostics if d.severity is not Severity.ERROR)
    if warnings and not quiet:  # the reporters are imported only to show something
        from fmionnx.reporters import FileResult
        from fmionnx.reporters.text import TextReporter

        TextReporter().render([FileResult(target, warnings)], sys.stderr, color=sys.stderr.isatty())
    return system


def _run_system(
    target: Path,
    *,
    out: Path | None,
    write: bool = True,
    force: bool = False,
    stop_time: float | None,
    params: dict[str, str],
    quiet: bool,
    record: Path | None,
    step: float | None,
    interface: str | None,
    ros2: Any = None,
    max_steps: int = MAX_RUN_STEPS,
    safety: RunSafety | None = None,
    evaluate: bool = True,
    plot_signals: bool = False,
    start_time: float | None = None,
    output_interval: float | None = None,
) -> int:
    import dataclasses

    from rich.console import Console

    from fmionnx.api import OverrideError, parse_value
    from fmionnx.core.errors import DiagnosticError, FmionnxError
    from fmionnx.runtime.result import RunOptions, RunStatus

    console = Console(stderr=True, highlight=False)
    kwargs: dict[str, Any] = {"step": step, "start": start_time}
    if target.suffix.lower() == ".fmu":
        kwargs["interface"] = interface
    system = load_target(target, quiet=quiet, **kwargs)
    try:
        system = system.with_overrides(
            stop_time=stop_time,
            params={k: parse_value(v) for k, v in params.items()},
            output_interval=output_interval,
        )
    except OverrideError as exc:
        raise fail(str(exc)) from None
    steps = system.compiled.run.steps
    if steps > max_steps:  # after the overrides: --stop-time changes the count
        raise fail(
            f"the run is {steps:.3g} base steps, more than --max-steps {max_steps:.3g}; "
            "check the stop time and step, or pass a larger --max-steps"
        )
    if out is None and write:  # the system's name is known now; still before the run
        from fmionnx.results.outdir import default_folder

        out = default_folder(system.name)
        _check_out(out, force=force, system_run=True, default=True)
    recorder = None
    if record is not None and ros2 is None:  # ROS 2: the supervisor records the wire
        from fmionnx.results.mcap_record import McapRecorder

        recorder = McapRecorder(record)
    options = RunOptions(frames=recorder)
    if ros2 is None and safety is not None:  # --isolate's default depends on the system
        safety = safety.resolved(system.compiled, record=record is not None)
        options = safety.options(options, system, out, console)
    run_fn = system.run
    ahead = None  # results.csv formatted while a guarded run goes on
    if ros2 is None and safety is not None:  # --isolate guardian: the run in a guarded child
        ahead = safety.csv_ahead(system, out)
        run_fn = safety.guard(system, run_fn, record=record is not None, ahead=ahead)
    if ros2 is not None:
        from fmionnx.backends.ros2.supervisor import run_ros2

        ros2 = dataclasses.replace(ros2, out=out)
        _check_rclpy_distro(system.compiled, ros2)

        def run_fn(*, options: RunOptions) -> Any:
            return run_ros2(system.compiled, dataclasses.replace(ros2, run=options))

    if not quiet:
        run = system.compiled.run
        where = "" if ros2 is None else f" as ROS 2 nodes ({ros2.sync.value})"
        how = ""
        if ros2 is None and safety is not None and safety.guardian:
            how = " in a guarded process"
            if safety.by_default:
                how += ", the default for a lone FMU"
        console.print(
            f"running {system.name}{where} from {run.start:g} to {run.stop:g} s{how} ...",
            soft_wrap=True,  # one line, as greppable as the short one
        )
    try:
        result = _with_progress(
            run_fn,
            system,
            options,
            quiet=quiet,
            console=console,
            guarded=ros2 is None and safety is not None and safety.guardian,
        )
    except DiagnosticError as exc:
        if recorder is not None:
            recorder.finish(None)
        raise fail(str(exc.diagnostics[0].message), ExitCode.PROBLEMS) from None
    except FmionnxError as exc:  # ROS 2: a bad ROS_DOMAIN_ID, DDS refusing to start
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    from fmionnx.cli.checks_report import failed, print_checks
    from fmionnx.runtime.checks import evaluate_checks

    checks = evaluate_checks(system.compiled.checks, result) if evaluate else ()
    files: list[Path] = []
    if recorder is not None:
        files.append(recorder.finish(result))
    elif record is not None and record.exists():
        files.append(record)
    if out is not None:
        from fmionnx.results import write_results

        files[:0] = write_results(
            result,
            system.compiled,
            out,
            aliases=dict(system.aliases),
            also=files,
            checks=checks,
            plot_signals=plot_signals,
            ahead=ahead,
        )
    if not quiet:
        _summary(console, result, files)
    print_checks(console, checks, quiet=quiet)
    if result.status is RunStatus.FAULT and result.error is not None:
        console.print(f"[bold red]fault:[/] {result.error}")
    elif result.status is RunStatus.INTERRUPTED:
        by = f" by {result.interrupted_by}" if result.interrupted_by else ""
        console.print(
            f"[yellow]interrupted{by}[/] at t={result.simulated_time + result.start:g} s; "
            "the results recorded so far are written"
        )
    elif result.ended_by is not None:
        ended = result.ended_by
        console.print(
            f"[green]ended[/] at t={ended.time:g} s by component `{ended.component}`: "
            f"{ended.reason}"
        )
    if out is not None:
        print(f"Results: {out}")  # the last line names the folder (make demo)
    if result.status is RunStatus.FAULT:
        return int(ExitCode.PROBLEMS)
    if result.status is RunStatus.INTERRUPTED:
        from fmionnx.runtime.stopping import exit_code

        return exit_code(result.interrupted_by)
    if failed(checks):  # the results are written: a failed check is a verdict, not a crash
        return int(ExitCode.PROBLEMS)
    return int(ExitCode.OK)


def _with_progress(
    run_fn: Any, system: Any, options: Any, *, quiet: bool, console: Any, guarded: bool = False
) -> Any:
    """``run_fn`` with a progress bar on a terminal.

    Under the guardian (``guarded``) the bar is refreshed by its updates (the guardian
    passes the child's progress on at up to 10 Hz) instead of by rich's refresh thread: the
    guardian forks, and a lock that thread held at the fork would be held in the child forever.
    """
    import dataclasses

    if quiet or not console.is_terminal:
        return run_fn(options=options)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    stop = system.compiled.run.stop
    started = time.perf_counter()
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("t = {task.fields[sim]:>8.3f} / " + f"{stop:g} s"),
        TextColumn("RTF {task.fields[rtf]:>6.2f}x"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        auto_refresh=not guarded,
    ) as progress:
        task = progress.add_task(system.name, total=system.compiled.run.steps, sim=0.0, rtf=0.0)

        def update(done: int, total: int, sim: float) -> None:
            wall = time.perf_counter() - started
            simulated = sim - system.compiled.run.start
            progress.update(task, completed=done, sim=sim, rtf=simulated / wall if wall else 0.0)
            if guarded:
                progress.refresh()

        return run_fn(options=dataclasses.replace(options, progress=update))


def _summary(console: Any, result: Any, files: list[Path]) -> None:
    from rich.table import Table

    table = Table(title=f"run of {result.system}", show_header=False, title_justify="left")
    table.add_column(style="bold")
    table.add_column()
    colour = {"completed": "green", "fault": "red", "interrupted": "yellow"}[result.status.value]
    table.add_row("status", f"[{colour}]{result.status.value}[/]")
    table.add_row(
        "simulated",
        f"{result.start:g} .. {result.start + result.simulated_time:g} s "
        f"({result.steps_done} steps of {result.step:g} s)",
    )
    table.add_row("wall time", f"{result.wall_time:.3f} s")
    table.add_row("real-time factor", f"{result.real_time_factor:.2f}x")
    table.add_row("signals", str(len(result.signals)))
    router = result.details.get("zenoh_router")
    if router:
        table.add_row("zenoh router", str(router))
    for file in files:
        table.add_row("wrote", str(file))
    console.print(table)


def _run_onnx(target: Path, inputs: dict[str, str], out: Path | None, *, quiet: bool) -> None:
    import io

    import numpy as np
    from rich.console import Console
    from rich.table import Table

    from fmionnx.api import OverrideError, run_onnx_once
    from fmionnx.core.errors import RunError
    from fmionnx.core.safewrite import write_bytes_atomic

    system = load_target(target, quiet=quiet)
    arrays = {}
    for name, file in inputs.items():
        try:
            arrays[name] = np.load(file, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise fail(f"--input {name}: cannot read `{file}` as a .npy array ({exc})") from None
    try:
        outputs = run_onnx_once(system, arrays)
    except (OverrideError, RunError) as exc:
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    console = Console(highlight=False)
    table = Table(title=f"outputs of {target.name}")
    for column in ("output", "dtype", "shape", "values"):
        table.add_column(column)
    for name, value in outputs.items():
        shown = np.array2string(value.reshape(-1)[:8], precision=6, separator=", ")
        if value.size > 8:
            shown = shown[:-1] + ", ...]"
        table.add_row(name, str(value.dtype), str(list(value.shape)), shown)
    if not quiet:
        console.print(table)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        for name, value in outputs.items():
            buffer = io.BytesIO()  # written atomically: never through a link planted there
            np.save(buffer, value)
            write_bytes_atomic(out / f"{name}.npy", buffer.getvalue())
        print(f"Results: {out}")  # the last line names the folder (make demo)
