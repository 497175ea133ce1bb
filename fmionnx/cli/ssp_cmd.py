"""``fmionnx export`` (system -> SSP) and ``fmionnx convert`` (SSP -> YAML system file)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from fmionnx.cli.app import ExitCode, app, fail
from fmionnx.cli.outputs import check_output_file

if TYPE_CHECKING:
    from fmionnx.core.diagnostics import DiagnosticBag

OutputOption = Annotated[Path, typer.Option("--output", "-o", help="File to write.")]
ForceOption = Annotated[
    bool, typer.Option("--force", help="Replace output files fmionnx did not write.")
]


def _refuse_unless_ours(check: Callable[[], None]) -> None:
    """Run an overwrite check before any work; a refusal is a usage error (exit 2)."""
    from fmionnx.core.safewrite import OverwriteRefusedError

    try:
        check()
    except OverwriteRefusedError as exc:
        raise fail(f"{exc}") from None


def _report(path: Path, bag: DiagnosticBag, *, errors_only: bool = False) -> None:
    from fmionnx.core.diagnostics import Severity
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    shown = tuple(d for d in bag.sorted() if not errors_only or d.severity is Severity.ERROR)
    if shown:
        REPORTER_BY_NAME["text"].render(
            [FileResult(path, shown)], sys.stderr, color=sys.stderr.isatty()
        )


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx export systems/sign_follower.yaml -o sign_follower.ssp\n\n"
    "  fmionnx export vendor.ssp -o normalized.ssp",
)
def export(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp, .ssd).")],
    output: OutputOption,
    force: ForceOption = False,
) -> None:
    """Write a system as an SSP 1.0 archive (SSD, models under resources/, parameters as .ssv).

    The system is compiled first: a system with errors is not exported. An existing archive
    is replaced only when fmionnx wrote it (else `--force`). See docs/ssp.md.
    """
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.core.diagnostics import DiagnosticBag
    from fmionnx.core.errors import FmionnxError
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.export.ssp_writer import check_export_target, export_ssp
    from fmionnx.spec.frontends import load_system

    if output.suffix.lower() != ".ssp":
        typer.echo(f"error: the output must end in .ssp (got `{output.name}`)", err=True)
        raise typer.Exit(ExitCode.USAGE)
    check_output_file(output, "--output")
    _refuse_unless_ours(lambda: check_export_target(output, force=force))
    bag = DiagnosticBag()
    loaded = load_system(system, bag)
    compiled = compile_spec(loaded, bag) if loaded.spec is not None else None
    if loaded.spec is None or compiled is None or bag.has_errors:
        _report(system, bag, errors_only=True)
        typer.echo("not exported: fix the errors above first", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
    try:
        export_ssp(loaded.spec, loaded.path.parent, output, compiled, force=force)
    except OverwriteRefusedError as exc:
        raise fail(f"{exc}") from None
    except FmionnxError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    typer.echo(f"wrote {output}")


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx convert vendor.ssp -o systems/vendor.yaml   # models go to systems/vendor_files/",
)
def convert(
    system: Annotated[Path, typer.Argument(help="System file (.ssp, .ssd, .yaml).")],
    output: OutputOption,
    force: ForceOption = False,
) -> None:
    """Write a system (usually an SSP) as a YAML system file.

    Only the system file is read; run `fmionnx validate` on the result to check the models.
    Models inside an .ssp archive are copied to `<output stem>_files/` beside the YAML file.
    A YAML file or `_files/` folder that convert did not write is replaced only with `--force`.
    """
    from fmionnx.core.diagnostics import DiagnosticBag
    from fmionnx.core.errors import FmionnxError
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.export.yaml_writer import (
        check_convert_targets,
        convert_header,
        write_yaml_system,
    )
    from fmionnx.spec.frontends import load_system

    if output.suffix.lower() not in {".yaml", ".yml"}:
        typer.echo(f"error: the output must end in .yaml (got `{output.name}`)", err=True)
        raise typer.Exit(ExitCode.USAGE)
    check_output_file(output, "--output")
    extracts = system.suffix.lower() == ".ssp"
    _refuse_unless_ours(lambda: check_convert_targets(output, extracts=extracts, force=force))
    bag = DiagnosticBag()
    loaded = load_system(system, bag)
    if loaded.spec is None or bag.has_errors:
        _report(system, bag, errors_only=True)
        typer.echo("not converted: fix the errors above first", err=True)
        raise typer.Exit(ExitCode.PROBLEMS)
    _report(system, bag)
    archive_root = loaded.sources.file.parent if extracts else None
    try:
        write_yaml_system(
            loaded.spec,
            loaded.path.parent,
            output,
            archive_root=archive_root,
            header=convert_header(system.name),
            force=force,
        )
    except OverwriteRefusedError as exc:
        raise fail(f"{exc}") from None
    except FmionnxError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(ExitCode.PROBLEMS) from None
    typer.echo(f"wrote {output}")
