"""``fmionnx lock``: record the interfaces a system was validated against."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app, fail


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx lock systems/sign_follower.yaml   # writes systems/sign_follower.fmionnx.lock\n\n"
    "  fmionnx validate --locked systems/sign_follower.yaml   # in CI",
)
def lock(
    systems: Annotated[list[Path], typer.Argument(help="System files (.yaml, .ssp, .ssd).")],
    force: Annotated[
        bool, typer.Option("--force", help="Replace a file at the lock's name not written by lock.")
    ] = False,
) -> None:
    """Write `<system>.fmionnx.lock` beside each system: the interface of every model.

    Commit the lock; `fmionnx validate --locked` then fails when a model's interface changes.
    A system with errors is not locked. A file at the lock's name that `fmionnx lock` did not
    write is replaced only with `--force`.
    """
    from fmionnx.core.diagnostics import Severity
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.lock.check import check_lock_target, lock_system
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    for system in systems:  # all checked first: a refusal leaves every lock as it was
        try:
            check_lock_target(system, force=force)
        except OverwriteRefusedError as exc:
            raise fail(f"{exc}") from None
    failed = []
    for system in systems:
        result = lock_system(system, force=force)
        shown = [d for d in result.diagnostics if d.severity is Severity.ERROR]
        if result.path is None:
            failed.append(FileResult(system, tuple(shown)))
            continue
        state = "wrote" if result.changed else "up to date:"
        typer.echo(f"{state} {result.path}")
    if failed:
        REPORTER_BY_NAME["text"].render(failed, sys.stderr, color=sys.stderr.isatty())
        typer.echo("not locked: fix the errors above first", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
