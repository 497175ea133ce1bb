"""What ``fmionnx run`` shows while and after a run: an observer of the run pipeline.

Warnings, the first line (``running sign_follower from 0 to 32 s ...``), a progress bar on a
terminal, then the summary table, the checks, how the run ended and, last, ``Results:
<folder>`` on stdout (``make demo`` and scripts read it). Everything else goes to stderr.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from rich.markup import escape
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn

from fmionnx.cli.checks_report import print_checks
from fmionnx.cli.console import make_console
from fmionnx.core.diagnostics import Diagnostic, Severity
from fmionnx.pipeline.observers import RunObserver, RunStart
from fmionnx.pipeline.outcome import RunOutcome
from fmionnx.pipeline.system import System
from fmionnx.runtime.result import Detail, RunResult, RunStatus


def show_diagnostics(target: Path, diagnostics: tuple[Diagnostic, ...] | list[Diagnostic]) -> None:
    """Diagnostics as ``validate`` renders them, on stderr."""
    from fmionnx.reporters import FileResult
    from fmionnx.reporters.text import TextReporter

    TextReporter().render(
        [FileResult(target, tuple(diagnostics))], sys.stderr, color=sys.stderr.isatty()
    )


class TerminalReport(RunObserver):
    """The CLI's observer: ``quiet`` keeps only failed checks, faults and the last line."""

    def __init__(self, target: Path, *, quiet: bool) -> None:
        self.console = make_console(stderr=True)
        self.target = target
        self.quiet = quiet
        self.wants_progress = not quiet and self.console.is_terminal
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self._started = 0.0
        self._start = 0.0
        self._guarded = False

    def loaded(self, system: System) -> None:
        """Warnings of the compiled system, unless quiet."""
        warnings = [d for d in system.diagnostics if d.severity is not Severity.ERROR]
        if warnings and not self.quiet:
            show_diagnostics(self.target, warnings)

    def before_run(self, start: RunStart) -> None:
        """The first line, then the progress bar.

        Under the guardian (``start.guarded``) the bar is refreshed by its updates (the
        guardian passes the child's progress on at up to 10 Hz) instead of by rich's refresh
        thread: the guardian forks, and a lock that thread held at the fork would be held in
        the child forever.
        """
        self._guarded = start.guarded
        run = start.system.compiled.run
        if not self.quiet:
            self.console.print(
                f"running {start.system.name}{start.where} from {run.start:g} to {run.stop:g} s"
                f"{start.how} ...",
                soft_wrap=True,  # one line, as greppable as the short one
            )
        if not self.wants_progress:
            return
        self._bar = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("t = {task.fields[sim]:>8.3f} / " + f"{run.stop:g} s"),
            TextColumn("RTF {task.fields[rtf]:>6.2f}x"),
            TimeElapsedColumn(),
            console=self.console,
            transient=True,
            auto_refresh=not start.guarded,
        )
        self._bar.start()
        self._task = self._bar.add_task(start.system.name, total=run.steps, sim=0.0, rtf=0.0)
        self._started, self._start = time.perf_counter(), run.start

    def progress(self, done: int, total: int, time_reached: float) -> None:
        """The bar's step count, simulated time and real-time factor."""
        if self._bar is None or self._task is None:
            return
        wall = time.perf_counter() - self._started
        simulated = time_reached - self._start
        rtf = simulated / wall if wall else 0.0
        self._bar.update(self._task, completed=done, sim=time_reached, rtf=rtf)
        if self._guarded:
            self._bar.refresh()

    def after_run(self) -> None:
        """The bar goes."""
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def abandoned(self, result: RunResult, out: Path | None) -> None:
        """The fault, or the stop and why it could not end the run as usual, and the folder:
        the process ends right after."""
        console = self.console
        if self._guarded:  # in the guarded child: the parent's console may be locked for good
            console = make_console(stderr=True)
        if result.status is RunStatus.INTERRUPTED:
            for warning in result.warnings:
                console.print(f"[yellow]warning:[/] {escape(warning)}", soft_wrap=True)
            console.print(
                f"[yellow]interrupted by {result.interrupted_by}[/] at "
                f"t={result.simulated_time + result.start:g} s; the results recorded so far "
                "are written"
            )
        else:
            console.print(f"[bold red]fault:[/] {result.error}")
        if out is not None:
            print(f"Results: {out}")
        sys.stdout.flush()

    def finished(self, outcome: RunOutcome) -> None:
        """Summary, checks, how the run ended, and the folder."""
        result = outcome.result
        if not self.quiet:
            if result.statistics is not None:
                from fmionnx.cli.profile_report import print_statistics

                print_statistics(self.console, result.statistics)
            self._summary(outcome)
        for warning in result.warnings:  # never silent, even with --quiet: run.json has them too
            self.console.print(f"[yellow]warning:[/] {escape(warning)}", soft_wrap=True)
        print_checks(self.console, outcome.checks, quiet=self.quiet)
        if result.status is RunStatus.FAULT and result.error is not None:
            self.console.print(f"[bold red]fault:[/] {result.error}")
        elif result.status is RunStatus.INTERRUPTED:
            by = f" by {result.interrupted_by}" if result.interrupted_by else ""
            self.console.print(
                f"[yellow]interrupted{by}[/] at t={result.simulated_time + result.start:g} s; "
                "the results recorded so far are written"
            )
        elif result.ended_by is not None:
            ended = result.ended_by
            self.console.print(
                f"[green]ended[/] at t={ended.time:g} s by component `{ended.component}`: "
                f"{ended.reason}"
            )
        if outcome.out is not None:
            print(f"Results: {outcome.out}")  # the last line names the folder (make demo)

    def _summary(self, outcome: RunOutcome) -> None:
        from rich.table import Table

        result = outcome.result
        table = Table(title=f"run of {result.system}", show_header=False, title_justify="left")
        table.add_column(style="bold")
        table.add_column()
        colour = {"completed": "green", "fault": "red", "interrupted": "yellow"}
        table.add_row("status", f"[{colour[result.status.value]}]{result.status.value}[/]")
        table.add_row(
            "simulated",
            f"{result.start:g} .. {result.start + result.simulated_time:g} s "
            f"({result.steps_done} steps of {result.step:g} s)",
        )
        table.add_row("wall time", f"{result.wall_time:.3f} s")
        table.add_row("real-time factor", f"{result.real_time_factor:.2f}x")
        if result.pacing is not None:
            table.add_row("pacing", pacing_text(result.pacing))  # escapes the names
        table.add_row("signals", str(len(result.signals)))
        router = result.details.get("zenoh_router")
        if router:
            table.add_row("zenoh router", str(router))
        for file in outcome.files:
            table.add_row("wrote", str(file))
        self.console.print(table)


def pacing_text(pacing: dict[str, Detail]) -> str:
    """The summary's pacing row: the pace, whether it kept up, late steps, the worst overrun."""
    late, steps = pacing.get("late_steps"), pacing.get("steps")
    text = f"{pacing.get('rtf')}x real time, " + (
        "kept up" if pacing.get("kept_up") else "[red]could not keep up[/]"
    )
    if late:
        text += (
            f"; {late} of {steps} steps late (largest {_seconds(pacing.get('max_lateness'))} "
            f"at t={pacing.get('max_lateness_at')} s)"
        )
    worst = pacing.get("worst_overrun")
    if isinstance(worst, dict):
        by = worst.get("by")
        spent = ", ".join(
            f"{name} {_seconds(value)}"
            for name, value in (by.items() if isinstance(by, dict) else ())
        )
        text += f"; longest step {_seconds(worst.get('took'))} at t={worst.get('time')} s: {escape(spent)}"
    return text


def _seconds(value: Detail) -> str:
    return f"{value * 1e3:.3g} ms" if isinstance(value, int | float) else "?"
