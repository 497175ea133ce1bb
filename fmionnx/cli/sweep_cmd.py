"""``fmionnx sweep``: run a study's cases on a local or an existing Dask cluster.

Dask and pyarrow are imported inside the command (through :mod:`fmionnx.pipeline.sweep`),
never when the CLI starts: ``fmionnx --help`` must not pay for them.
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from fmionnx.cli.app import ExitCode, QuietOption, app, fail
from fmionnx.cli.run_options import folder_path

if TYPE_CHECKING:
    from rich.console import Console
    from rich.progress import Progress, TaskID

    from fmionnx.core.diagnostics import Diagnostic
    from fmionnx.pipeline.sweep import SweepProgress, SweepResult

#: Rows of the ranked table printed for an objective.
RANKED_ROWS = 10


StudyOut = Annotated[
    Path,
    typer.Option(
        "--out", "-o", parser=folder_path, metavar="<path>",
        help="Results folder (new, or --resume).",
    ),
]  # fmt: skip
# No `min=1` on the counts: the pipeline checks them (`fmionnx.sweep` too) and says so in the
# project's words, `error: --workers takes ...`, where Typer printed its own box.
Workers = Annotated[
    int | None, typer.Option("--workers", "-w", help="Local worker processes (default: cores).")
]
Batch = Annotated[
    int | None,
    typer.Option(
        "--batch",
        help="Cases per Dask task (1: one each; default: short cases batched by their time).",
    ),
]


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx sweep study.yaml --out sweeps/gains\n\n"
    "  fmionnx sweep study.yaml --out sweeps/gains --scheduler tcp://10.0.0.5:8786\n\n"
    "  fmionnx sweep study.yaml --out sweeps/gains --resume   # after an interruption",
)
def sweep(
    study: Annotated[Path, typer.Argument(help="Study file (YAML): the system and what to vary.")],
    out: StudyOut,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler", help="An existing Dask cluster's scheduler (`tcp://HOST:8786`)."
        ),
    ] = None,
    workers: Workers = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Finish an interrupted study in --out.")
    ] = False,
    keep_results: Annotated[
        bool,
        typer.Option("--keep-results", help="Keep each case's results.csv (cases/<id>/)."),
    ] = False,
    rrd: Annotated[
        bool, typer.Option("--rrd", help="Keep each case's Rerun recording (cases/<id>/run.rrd).")
    ] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Replace the results of a study already in --out.")
    ] = False,
    batch: Batch = None,
    quiet: QuietOption = False,
) -> None:
    """Run every case of a study in parallel and write one row per case (cases.parquet/.csv).

    The system is compiled once; each case is the compiled system with the study's settings
    applied, run in-process on a worker (FMUs isolated by default). A failing case is
    recorded with its diagnostic and the study goes on.
    """
    if scheduler is None:
        _fork_server()
    from fmionnx.backends.sweep.engine import ClusterStartError, SchedulerError
    from fmionnx.cli.app import refused
    from fmionnx.cli.console import make_console
    from fmionnx.core.errors import DiagnosticError
    from fmionnx.core.modelfiles import ShippingError
    from fmionnx.pipeline.sweep import sweep_study
    from fmionnx.results.study import StudyFolderError
    from fmionnx.runtime.stopping import stop_on_signals

    def warn(found: tuple[Diagnostic, ...]) -> None:
        if not quiet:
            _show(study, found)

    console = make_console()
    try:  # SIGTERM and SIGHUP stop a study as Ctrl-C does (the finished cases kept)
        with stop_on_signals(process_ends=True), refused(), _progress(console, quiet) as update:
            result = sweep_study(
                study, out, scheduler=scheduler, workers=workers, resume=resume,
                keep_results=keep_results, force=force, progress=update, batch=batch,
                warnings=warn, rrd=rrd,
            )  # fmt: skip
    except DiagnosticError as exc:
        _show(study, tuple(exc.diagnostics))
        raise typer.Exit(ExitCode.PROBLEMS) from None
    except StudyFolderError as exc:
        raise fail(str(exc)) from None
    except (SchedulerError, ClusterStartError, ShippingError) as exc:
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    except KeyboardInterrupt as exc:  # the finished cases are recorded: nothing to lose
        raise _interrupted(console, out, exc) from None
    if not quiet:
        _summary(console, result)
    failed = sum(status != "ok" for status in result.cases.column("status"))
    if failed:
        raise typer.Exit(ExitCode.PROBLEMS)


def _fork_server() -> None:
    """Start the server the local cluster's workers are forked from, while the study compiles
    (:mod:`fmionnx.backends.sweep.workerfork`), in a process that is this command alone; it
    also imports the pipeline's case runner and the backend it runs a case on."""
    from fmionnx.backends.sweep import workerfork
    from fmionnx.cli import whole_process

    if whole_process():
        workerfork.start(also=("fmionnx.pipeline.study", "fmionnx.backends.inprocess"))


def _interrupted(console: Console, out: Path, stop: KeyboardInterrupt) -> typer.Exit:
    """Say where the finished cases are; the exit a stop signal gives (128 + its number)."""
    from fmionnx.runtime.stopping import exit_code, stop_reason

    reason = stop_reason(stop)
    console.print(
        f"interrupted by {reason}: the finished cases are in {out}; `--resume` runs the rest"
    )
    return typer.Exit(exit_code(reason))


def _show(study: Path, diagnostics: tuple[Diagnostic, ...]) -> None:
    """Diagnostics of the study file, rendered like ``validate``'s, on stderr."""
    from fmionnx.reporters import FileResult
    from fmionnx.reporters.text import TextReporter

    TextReporter().render([FileResult(study, diagnostics)], sys.stderr, color=sys.stderr.isatty())


class _progress:  # noqa: N801 - used as a function-like context manager
    """A rich progress bar (cases done, failed, ETA) on a terminal; silent otherwise."""

    def __init__(self, console: Console, quiet: bool) -> None:
        self.console = console
        self.quiet = quiet or not console.is_terminal
        self.bar: Progress | None = None
        self.task: TaskID | None = None

    def __enter__(self) -> SweepProgress | None:
        if self.quiet:
            return None
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = Progress(
            TextColumn("[bold]cases"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("[red]{task.fields[failed]} failed"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=self.console,
            transient=True,
        )
        self.bar.__enter__()
        self.task = self.bar.add_task("cases", total=None, failed=0)
        return self.update

    def update(self, done: int, failed: int, total: int) -> None:
        assert self.bar is not None
        assert self.task is not None
        self.bar.update(self.task, completed=done, total=total, failed=failed)

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def _summary(console: Console, result: SweepResult) -> None:
    from rich.table import Table

    from fmionnx.results.study import ranked

    table = result.cases
    counts = collections.Counter(table.column("status"))
    overview = Table(title=f"study {result.plan.name}", show_header=False, title_justify="left")
    overview.add_column(style="bold")
    overview.add_column()
    overview.add_row("cases", str(len(result.plan.cases)))
    if result.resumed:
        overview.add_row("resumed", f"{result.resumed} finished before")
    if result.damaged:
        overview.add_row(
            "run again", f"{result.damaged} whose record was damaged (records/<case>.json)"
        )
    for status in ("ok", "fault", "timeout", "failed"):
        if counts.get(status, 0):
            colour = "green" if status == "ok" else "red"
            overview.add_row(status, f"[{colour}]{counts[status]}[/]")
    for check in result.plan.check_names:
        column = table.column("check: " + check)
        overview.add_row(f"check {check}", f"{sum(column)} of {len(column)} passed")
    for file in result.files:
        overview.add_row("wrote", str(file))
    console.print(overview)
    best = ranked(table, result.plan)
    objective = result.plan.objective
    if objective is None or not best:
        return
    ranking = Table(
        title=f"best cases ({objective.sense} {objective.metric})", title_justify="left"
    )
    columns = ["case", *result.plan.targets, *(m.name for m in result.plan.metrics)]
    for name in columns:
        ranking.add_column(name, justify="left" if name == "case" else "right")
    for row in best[:RANKED_ROWS]:
        ranking.add_row(*(_cell(row[name]) for name in columns))
    console.print(ranking)


def _cell(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)
