"""``fmionnx graph``: draw the compiled dataflow graph."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app, fail
from fmionnx.cli.outputs import (
    check_output_file,
    refuse_an_input,
    write_derived,
)

#: Text formats and the writer in fmionnx.export.graph (imported when the command runs).
TEXT_FORMATS = {"dot": "to_dot", "mermaid": "to_mermaid", "json": "to_json_text"}
IMAGE_FORMATS = ("svg", "png")
#: The format an ``--output`` file's suffix stands for when ``--format`` is not given.
FORMAT_OF_SUFFIX = {
    ".dot": "dot",
    ".gv": "dot",
    ".mmd": "mermaid",
    ".mermaid": "mermaid",
    ".json": "json",
    ".svg": "svg",
    ".png": "png",
}


def _check_format(value: str | None) -> str | None:
    if value is not None and value not in TEXT_FORMATS and value not in IMAGE_FORMATS:
        names = ", ".join([*TEXT_FORMATS, *IMAGE_FORMATS])
        msg = f"unknown format `{value}`; expected one of {names}"
        raise typer.BadParameter(msg)
    return value


def format_of(output: Path | None) -> str:
    """The format ``--output``'s suffix stands for (DOT on stdout); exit 2 for an unknown one.

    Writing DOT text into ``graph.svg`` because ``-f`` was left out would give a file no
    viewer opens; an unknown suffix is refused rather than guessed.
    """
    if output is None:
        return "dot"
    found = FORMAT_OF_SUFFIX.get(output.suffix.lower())
    if found is None:
        known = ", ".join(f"`{suffix}`" for suffix in FORMAT_OF_SUFFIX)
        shown = f"`{output.suffix}`" if output.suffix else "no suffix"
        msg = (
            f"--output `{output}` has {shown}: the format cannot be told from it; "
            f"give `--format` ({', '.join([*TEXT_FORMATS, *IMAGE_FORMATS])}) or a file "
            f"ending in {known}"
        )
        raise fail(msg)
    return found


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx graph systems/sign_follower.yaml                 # DOT on stdout\n\n"
    "  fmionnx graph systems/sign_follower.yaml -o graph.mmd        # Mermaid, from the suffix\n\n"
    "  fmionnx graph systems/sign_follower.yaml -o graph.svg        # needs Graphviz",
)
def graph(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp, .ssd).")],
    output_format: Annotated[
        str | None,
        typer.Option(
            "--format",
            "-f",
            callback=_check_format,
            show_default=False,
            help="dot, mermaid, json, svg, png. Default: from the suffix of --output "
            "(.dot/.gv, .mmd/.mermaid, .json, .svg, .png), DOT on stdout.",
        ),
    ] = None,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="File to write.")] = None,
) -> None:
    """Compile a system and print or write its dataflow graph."""
    from fmionnx import api
    from fmionnx.export import graph as writers
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    if output_format is None:
        output_format = format_of(output)
    if output is not None:
        check_output_file(output, "--output")
    result = api.compile_system(system)
    if result.system is None:
        REPORTER_BY_NAME["text"].render(
            [FileResult(system, result.diagnostics)], sys.stderr, color=sys.stderr.isatty()
        )
        raise typer.Exit(ExitCode.PROBLEMS)
    if output is not None:
        refuse_an_input(output, [system, *(c.path for c in result.system.components)])
    if output_format in TEXT_FORMATS:
        text = getattr(writers, TEXT_FORMATS[output_format])(result.system)
        if output is None:
            typer.echo(text, nl=False)
        else:
            write_derived(output, text)
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
        [dot, f"-T{output_format}"],
        input=writers.to_dot(result.system).encode(),
        capture_output=True,
        check=False,
    )
    if rendered.returncode != 0:
        from fmionnx.core.printable import printable

        # Graphviz quotes the label it choked on: text from a model file, shown escaped.
        reason = printable(rendered.stderr.decode(errors="replace").rstrip())
        typer.echo(f"error: Graphviz failed: {reason}", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
    write_derived(output, rendered.stdout)  # atomically, never through a link
