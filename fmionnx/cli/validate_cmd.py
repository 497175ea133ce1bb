"""``fmionnx validate``: check system files like a compiler."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx import api
from fmionnx.cli.app import ExitCode, app
from fmionnx.diagnostics import Severity
from fmionnx.reporters import REPORTER_BY_NAME, FileResult


def _check_format(value: str) -> str:
    if value not in REPORTER_BY_NAME:
        names = ", ".join(sorted(REPORTER_BY_NAME))
        msg = f"unknown format `{value}`; expected one of {names}"
        raise typer.BadParameter(msg)
    return value


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx validate systems/sign_follower.yaml\n\n"
    "  fmionnx validate systems/*.yaml --format json > report.json",
)
def validate(
    systems: Annotated[list[Path], typer.Argument(help="System files (.yaml, .ssp, .ssd).")],
    output_format: Annotated[
        str,
        typer.Option(
            "--format", "-f", callback=_check_format, help="Report format: text, json, ..."
        ),
    ] = "text",
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Report errors only.")] = False,
) -> None:
    """Check system files and the models they use; exit 1 when anything is wrong."""
    results = []
    for path in systems:
        result = api.compile_system(path)
        diagnostics = result.diagnostics
        if quiet:
            diagnostics = tuple(d for d in diagnostics if d.severity is Severity.ERROR)
        results.append(FileResult(path, diagnostics))
    reporter = REPORTER_BY_NAME[output_format]
    reporter.render(results, sys.stdout, color=sys.stdout.isatty())
    worst = max((r.worst for r in results if r.worst is not None), default=None)
    raise typer.Exit(ExitCode.PROBLEMS if worst is Severity.ERROR else ExitCode.OK)
