"""``fmionnx build-fmu``: compile a source-code FMU for this platform."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app, fail
from fmionnx.cli.outputs import check_output_file, refuse_an_input


@app.command(
    "build-fmu",
    epilog="Examples:\n\n"
    "  fmionnx build-fmu tests/fixtures/fmus/Gain -o build/Gain.fmu\n\n"
    "  fmionnx build-fmu WindowsOnly.fmu   # writes WindowsOnly.built.fmu",
)
def build_fmu_command(
    source: Annotated[Path, typer.Argument(help="Source FMU: a folder or .fmu with sources/.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", help="FMU to write.")] = None,
    force: Annotated[
        bool,
        typer.Option("--force", help="Replace an output file build-fmu did not write."),
    ] = False,
) -> None:
    """Compile a source FMU (C sources inside) into a binary FMU for this platform.

    Binaries for other platforms are kept. An existing output is replaced only when build-fmu
    wrote it (else `--force`); the source itself, never.
    """
    from rich.markup import escape

    from fmionnx.cli.console import make_console
    from fmionnx.core.errors import BuildError, ModelError
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.kinds.fmu.build import build_fmu, check_build_target, default_output

    err = make_console(stderr=True, soft_wrap=True)
    option = "--output"
    if output is None:
        option = "the output"
        try:
            output = default_output(source)
        except ValueError as exc:
            raise fail(str(exc)) from None
    check_output_file(output, option)
    _refuse_the_source(output, source, option)
    try:
        check_build_target(output, force=force)
    except OverwriteRefusedError as exc:
        raise fail(str(exc)) from None
    try:
        written = build_fmu(source, output)
    except ModelError as exc:
        err.print(f"[bold red]error\\[{exc.code.code}][/]: {escape(str(exc))}")
        if exc.hint:
            err.print(f"  hint: {exc.hint}", markup=False)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    except BuildError as exc:
        err.print(f"[bold red]error[/]: {escape(str(exc))}")
        err.print(exc.log, markup=False)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    make_console(soft_wrap=True).print(f"built {written}", markup=False)


def _refuse_the_source(output: Path, source: Path, option: str) -> None:
    """Exit 2 when ``output`` is the source FMU, or inside the source folder (the build reads
    every file of it: the next build would pack this one), even with ``--force``: a vendor's
    FMU rebuilt over itself would lose its other platforms' binaries for good."""
    refuse_an_input(output, [source], option)
    if not source.is_dir():
        return
    try:
        inside = output.resolve().is_relative_to(source.resolve())
    except OSError:
        return
    if inside:
        msg = (
            f"{option} `{output}` lies inside the source folder `{source}`, which the build "
            "packs whole: choose a name outside it"
        )
        raise fail(msg)
