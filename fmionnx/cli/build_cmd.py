"""``fmionnx build-fmu``: compile a source-code FMU for this platform."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.outputs import check_output_file


@app.command(
    "build-fmu",
    epilog="Examples:\n\n"
    "  fmionnx build-fmu tests/fixtures/fmus/Gain -o build/Gain.fmu\n\n"
    "  fmionnx build-fmu WindowsOnly.fmu   # writes WindowsOnly.built.fmu",
)
def build_fmu_command(
    source: Annotated[Path, typer.Argument(help="Source FMU: a folder or .fmu with sources/.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", help="FMU to write.")] = None,
) -> None:
    """Compile a source FMU (C sources inside) into a binary FMU for this platform."""
    from rich.markup import escape

    from fmionnx.cli.console import make_console
    from fmionnx.core.errors import BuildError, ModelError
    from fmionnx.kinds.fmu.build import build_fmu

    err = make_console(stderr=True, soft_wrap=True)
    if output is not None:
        check_output_file(output, "--output")
    try:
        written = build_fmu(source, output)
    except ModelError as exc:
        err.print(f"[bold red]error\\[{exc.code}][/]: {escape(str(exc))}")
        if exc.hint:
            err.print(f"  hint: {exc.hint}", markup=False)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    except BuildError as exc:
        err.print(f"[bold red]error[/]: {escape(str(exc))}")
        err.print(exc.log, markup=False)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    make_console(soft_wrap=True).print(f"built {written}", markup=False)
