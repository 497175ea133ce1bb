"""``fmionnx compile``: write the compiled system (and its models by hash) for another host."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, QuietOption, app, fail
from fmionnx.cli.outputs import check_output_file, check_output_folder


@app.command(
    "compile",
    epilog="Examples:\n\n"
    "  fmionnx compile systems/sign_follower.yaml -o robot.fmionnx.json --models models/\n\n"
    "  fmionnx node robot.fmionnx.json tracker --models models/   # on another host",
)
def compile_(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp) or a single model.")],
    output: Annotated[
        Path, typer.Option("--output", "-o", help="Compiled-system file to write (*.fmionnx.json).")
    ],
    models: Annotated[
        Path | None,
        typer.Option(
            "--models", help="Also copy every model into this folder, named by content hash."
        ),
    ] = None,
    stop_time: Annotated[
        float | None, typer.Option("--stop-time", help="Stop time in seconds (overrides).")
    ] = None,
    param: Annotated[
        list[str] | None, typer.Option("--param", "-p", help="`component.name=value`.")
    ] = None,
    force: Annotated[
        bool,
        typer.Option(
            "--force", help="Replace --output even when it is not a compiled system fmionnx wrote."
        ),
    ] = False,
    quiet: QuietOption = False,
) -> None:
    """Compile once and write the result: nodes and workers start from it, nothing recompiles.

    The file holds the checked system (components with their resolved settings, connections,
    schedule, records, plots, the ROS 2 plan) and the content hash of every model it needs.
    An existing --output is replaced only when it is a compiled system (else `--force`);
    --models copies each model with the files it references, nothing else of its folder.
    """
    from fmionnx.api import OverrideError
    from fmionnx.cli.app import refused
    from fmionnx.cli.run_cmd import load_target
    from fmionnx.compile.systemfile import (
        SUFFIX,
        check_compile_target,
        place_models,
        write_compiled,
    )
    from fmionnx.core.modelfiles import ShippingError
    from fmionnx.core.safewrite import OverwriteRefusedError
    from fmionnx.pipeline.request import params_from_text

    if not output.name.endswith(SUFFIX):
        raise fail(f"--output `{output}` must end with `{SUFFIX}` (how nodes recognise it)")
    check_output_file(output, "--output")
    try:
        check_compile_target(output, force=force)
    except OverwriteRefusedError as exc:
        raise fail(str(exc)) from None
    if models is not None:
        check_output_folder(models, "--models")
    with refused():
        params = params_from_text(param or [])
    loaded = load_target(system, quiet=quiet)
    try:
        compiled = loaded.with_overrides(stop_time=stop_time, params=params).compiled
    except OverrideError as exc:
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    try:
        placed = place_models(compiled, models) if models is not None else []
    except ShippingError as exc:
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    write_compiled(compiled, output)
    if not quiet:
        typer.echo(f"wrote {output} (content hash {compiled.content_hash[:16]})")
        for path in placed:
            typer.echo(f"model {path.parent.name[:16]}  {path.name}")
