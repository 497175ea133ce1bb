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
    Every system is compiled before any lock is written: one with errors locks none. A file
    at the lock's name that `fmionnx lock` did not write, or the lock of another system that
    shares the name (`robot.yml` beside `robot.yaml`), is replaced only with `--force`.
    """
    from fmionnx.core.diagnostics import Severity
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.lock.check import check_lock_target, prepare_lock, write_lock
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    systems = _distinct(systems)
    for system in systems:  # all checked first: a refusal leaves every lock as it was
        try:
            check_lock_target(system, force=force)
        except OverwriteRefusedError as exc:
            raise fail(f"{exc}") from None
    prepared = [prepare_lock(system) for system in systems]  # then all compiled
    failed = [
        FileResult(p.system, tuple(d for d in p.diagnostics if d.severity is Severity.ERROR))
        for p in prepared
        if p.text is None
    ]
    if failed:
        REPORTER_BY_NAME["text"].render(failed, sys.stderr, color=sys.stderr.isatty())
        nothing = "" if len(systems) == 1 else " (no lock was written)"
        typer.echo(f"not locked: fix the errors above first{nothing}", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
    for one in prepared:
        result = write_lock(one)
        state = "wrote" if result.changed else "up to date:"
        typer.echo(f"{state} {result.path}")


def _distinct(systems: list[Path]) -> list[Path]:
    """``systems`` with repeats of one file dropped; exit 2 when two different systems would
    write one lock (``robot.yaml robot.yml``): the second would replace the first's."""
    from fmionnx.lock.model import lock_path

    kept: list[Path] = []
    owners: dict[Path, Path] = {}
    for system in systems:
        if any(_same(system, other) for other in kept):
            continue
        kept.append(system)
        if system.is_dir():
            continue  # no lock: compiling it says what it is (E011)
        lock = lock_path(system).absolute()
        other = owners.setdefault(lock, system)
        if other is not system:
            msg = (
                f"`{other}` and `{system}` share the lock name `{lock_path(system)}`: lock "
                "them one at a time (each with --force replaces the other's lock), or rename one"
            )
            raise fail(msg)
    return kept


def _same(one: Path, other: Path) -> bool:
    """Two names of one file (a missing file is itself only)."""
    try:
        return one.samefile(other)
    except OSError:
        return one == other
