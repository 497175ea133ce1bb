"""``fmionnx run``: run a system in-process or as ROS 2 nodes (or one FMU / ONNX model in-process)
and write its results.

The command parses its flags into the keyword arguments the Python API takes
(:class:`~fmionnx.pipeline.request.RunSettings`), hands them to the run pipeline
(:mod:`fmionnx.pipeline`) and prints what its observer (:mod:`.run_report`) reports: every
check of the options, the defaults and the order of the stages live there.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from fmionnx.cli.app import ExitCode, app, fail, refused
from fmionnx.cli.run_options import (
    CHECKPOINT_EVERY,
    MAX_RUN_STEPS,
    STEP_TIMEOUT,
    Backend,
    CheckpointEvery,
    Checks,
    Force,
    Inputs,
    InputWait,
    Interface,
    Isolate,
    MaxSteps,
    Middleware,
    NoOut,
    OnNonfinite,
    Out,
    OutputInterval,
    Param,
    Plot,
    Profile,
    Quiet,
    Record,
    RosDistro,
    Rrd,
    Rtf,
    Sandbox,
    Schedule,
    StartTime,
    Step,
    StepTimeout,
    StopTime,
    Sync,
    Target,
    View,
    ZenohRouter,
)

if TYPE_CHECKING:  # the pipeline loads when a command runs, not for --help
    from fmionnx.pipeline.request import RunRequest
    from fmionnx.pipeline.system import System


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx run systems/sign_follower.yaml            # results in out/sign_follower/\n\n"
    "  fmionnx run systems/sign_follower.yaml --out out/demo\n\n"
    "  fmionnx run systems/sign_follower.yaml --stop-time 10 --param tracker.turnRate=0.6\n\n"
    "  fmionnx run model.fmu --stop-time 5 --step 0.01 --interface me --out out/model\n\n"
    "  fmionnx run model.fmu -p k=2                      # a single FMU: bare variable names\n\n"
    "  fmionnx run model.fmu --plot                      # and signals.png of its outputs\n\n"
    "  fmionnx run detector.onnx --input image=frame.npy --out out/detector\n\n"
    "  fmionnx run systems/sign_follower.yaml --view rerun        # live in Rerun\n\n"
    "  fmionnx run systems/sign_follower.yaml --profile --rtf 1   # statistics, real time\n\n"
    "  fmionnx run systems/sign_follower.yaml --backend ros2 --sync lockstep --out out/ros2",
)
def run(
    target: Target,
    out: Out = None,
    no_out: NoOut = False,
    stop_time: StopTime = None,
    param: Param = None,
    quiet: Quiet = False,
    record: Record = None,
    step: Step = None,
    start_time: StartTime = None,
    output_interval: OutputInterval = None,
    interface: Interface = None,
    inputs: Inputs = None,
    backend: Backend = "inprocess",
    sync: Sync = None,
    ros_distro: RosDistro = None,
    middleware: Middleware = None,
    zenoh_router: ZenohRouter = None,
    rtf: Rtf = None,
    input_wait: InputWait = None,
    step_timeout: StepTimeout = STEP_TIMEOUT,
    isolate: Isolate = None,
    sandbox: Sandbox = False,
    schedule: Schedule = None,
    checkpoint_every: CheckpointEvery = CHECKPOINT_EVERY,
    force: Force = False,
    checks: Checks = True,
    max_steps: MaxSteps = MAX_RUN_STEPS,
    plot: Plot = False,
    profile: Profile = False,
    on_nonfinite: OnNonfinite = None,
    view: View = None,
    rrd: Rrd = None,
) -> None:
    """Run a system in-process or as ROS 2 nodes (--backend ros2), or a single FMU / ONNX model.

    Results go to --out, by default out/<system name>/; the last line names the folder. A fault
    or a failed check exits 1 after writing what was recorded; Ctrl-C exits 130, SIGTERM 143.
    """
    _forkable()
    from fmionnx.pipeline.request import build_request, pairs, params_from_text

    with refused():
        request = build_request(
            target, backend=backend, out=out, no_out=no_out, stop_time=stop_time,
            params=params_from_text(param or []), record=record, step=step,
            start_time=start_time, output_interval=output_interval, interface=interface,
            inputs=pairs(inputs or [], "--input"), sync=sync, ros_distro=ros_distro,
            middleware=middleware, zenoh_router=zenoh_router, rtf=rtf, input_wait=input_wait,
            step_timeout=step_timeout, isolate=isolate, sandbox=sandbox or None,
            schedule=schedule, checkpoint_every=checkpoint_every, force=force, checks=checks,
            max_steps=max_steps, plot=plot, profile=profile, on_nonfinite=on_nonfinite,
            view=view, rrd=rrd,
        )  # fmt: skip
        if request.kind == "inference":
            _infer(request, quiet=quiet)
            return
        raise typer.Exit(_run(request, quiet=quiet))


def _forkable() -> None:
    """In the command's own process (not a program calling :func:`fmionnx.cli.main`), before
    numpy loads: its run's helpers may be forks of it, and numpy starts one BLAS thread so
    that it has one thread to be forked with (:mod:`fmionnx.core.forking`)."""
    from fmionnx.cli import whole_process

    if whole_process():
        from fmionnx.core.forking import allow_forked_helpers, load_numpy_with_one_blas_thread

        load_numpy_with_one_blas_thread()
        allow_forked_helpers()


def _run(request: RunRequest, *, quiet: bool) -> int:
    """Run ``request`` through the pipeline under the CLI's stop signals; the exit status.

    A system file's errors are rendered like ``validate``'s (exit 1).
    """
    from fmionnx.cli.run_report import TerminalReport, show_diagnostics
    from fmionnx.core.errors import DiagnosticError
    from fmionnx.pipeline.run import execute
    from fmionnx.runtime.stopping import exit_code, stop_on_signals, stop_reason

    report = TerminalReport(request.target, quiet=quiet)
    try:
        with stop_on_signals(process_ends=True):  # SIGTERM/SIGHUP stop like Ctrl-C
            return execute(request, [report]).exit_status
    except DiagnosticError as exc:
        show_diagnostics(request.target, exc.diagnostics)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    except KeyboardInterrupt as exc:
        reason = stop_reason(exc)
        raise fail(f"interrupted by {reason} before the run started", exit_code(reason)) from None


def _infer(request: RunRequest, *, quiet: bool) -> None:
    """A single ONNX model inferred once (the pipeline's path, :func:`fmionnx.run`'s too): a
    table of its outputs, then the folder."""
    import numpy as np
    from rich.table import Table

    from fmionnx.cli.console import make_console
    from fmionnx.cli.run_report import show_diagnostics
    from fmionnx.core.errors import DiagnosticError
    from fmionnx.pipeline.infer import InferenceOutcome
    from fmionnx.pipeline.run import execute

    try:
        done = execute(request)
    except DiagnosticError as exc:
        show_diagnostics(request.target, exc.diagnostics)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    assert isinstance(done, InferenceOutcome)  # an .onnx target is inferred (execute)
    table = Table(title=f"outputs of {request.target.name}")
    for column in ("output", "dtype", "shape", "values"):
        table.add_column(column)
    for name, value in done.outputs.items():
        shown = np.array2string(value.reshape(-1)[:8], precision=6, separator=", ")
        if value.size > 8:
            shown = shown[:-1] + ", ...]"
        table.add_row(name, str(value.dtype), str(list(value.shape)), shown)
    if not quiet:
        make_console().print(table)
    if done.out is not None:
        print(f"Results: {done.out}")  # the last line names the folder (make demo)
    sys.stdout.flush()


def load_target(target: Path, *, quiet: bool, models: Path | None = None) -> System:
    """``target`` loaded for a command that compiles or runs it: its errors rendered like
    ``validate`` (exit 1), its warnings unless quiet; a usage error exits 2."""
    from fmionnx.cli.run_report import show_diagnostics
    from fmionnx.core.diagnostics import Severity
    from fmionnx.core.errors import DiagnosticError
    from fmionnx.pipeline.request import build_request
    from fmionnx.pipeline.run import load_request

    with refused():
        request = build_request(target, models=models)
        try:
            system = load_request(request)
        except DiagnosticError as exc:
            show_diagnostics(target, exc.diagnostics)
            raise typer.Exit(ExitCode.PROBLEMS) from None
    warnings = [d for d in system.diagnostics if d.severity is not Severity.ERROR]
    if warnings and not quiet:
        show_diagnostics(target, warnings)
    return system
