"""``fmionnx graph``: draw the compiled dataflow graph."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.outputs import check_output_file

#: Text formats and the writer in fmionnx.export.graph (imported when the command runs).
TEXT_FORMATS = {"dot": "to_dot", "mermaid": "to_mermaid", "json": "to_json_text"}
IMAGE_FORMATS = ("svg", "png")


def _check_format(value: str) -> str:
    if value not in TEXT_FORMATS and value not in IMAGE_FORMATS:
        names = ", ".join([*TEXT_FORMATS, *IMAGE_FORMATS])
        msg = f"unknown format `{value}`; expected one of {names}"
        raise typer.BadParameter(msg)
    return value


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx graph systems/sign_follower.yaml                 # DOT on stdout\n\n"
    "  fmionnx graph systems/sign_follower.yaml -f mermaid -o graph.md\n\n"
    "  fmionnx graph systems/sign_follower.yaml -f svg -o graph.svg   # needs Graphviz",
)
def graph(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp, .ssd).")],
    output_format: Annotated[
        str,
        typer.Option(
            "--format", "-f", callback=_check_format, help="dot, mermaid, json, svg, png."
        ),
    ] = "dot",
    output: Annotated[Path | None, typer.Option("--output", "-o", help="File to write.")] = None,
) -> None:
    """Compile a system and print or write its dataflow graph."""
    from fmionnx import api
    from fmionnx.export import graph as writers
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    if output is not None:
        check_output_file(output, "--output")
    result = api.compile_system(system)
    if result.system is None:
        REPORTER_BY_NAME["text"].render(
            [FileResult(system, result.diagnostics)], sys.stderr, color=sys.stderr.isatty()
        )
        raise typer.Exit(ExitCode.PROBLEMS)
    if output_format in TEXT_FORMATS:
        text = getattr(writers, TEXT_FORMATS[output_format])(result.system)
        if output is None:
            typer.echo(text, nl=False)
        else:
            output.write_text(text, encoding="utf-8")
        return
    dot = shutil.which("dot")
    if dot is None:
        typer.echo(
            f"error: `--format {output_format}` needs Graphviz's `dot` program "
            "(Debian: apt-get install graphviz); `--format dot` works without it",
            err=True,
        )
        raise typer.Exit(ExitCode.USAGE)
    if output is None:
        typer.echo(f"error: `--format {output_format}` needs `--output FILE`", err=True)
        raise typer.Exit(ExitCode.USAGE)
    rendered = subprocess.run(
        [dot, f"-T{output_format}", "-o", str(output)],
        input=writers.to_dot(result.system).encode(),
        capture_output=True,
        check=False,
    )
    if rendered.returncode != 0:
        typer.echo(f"error: Graphviz failed: {rendered.stderr.decode(errors='replace')}", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
