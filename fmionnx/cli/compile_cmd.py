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
    quiet: QuietOption = False,
) -> None:
    """Compile once and write the result: nodes and workers start from it, nothing recompiles.

    The file holds the checked system (components with their resolved settings, connections,
    schedule, records, plots, the ROS 2 plan) and the content hash of every model it needs.
    """
    from fmionnx.api import OverrideError
    from fmionnx.cli.app import refused
    from fmionnx.cli.run_cmd import load_target
    from fmionnx.compile.systemfile import SUFFIX, place_models, write_compiled
    from fmionnx.pipeline.request import params_from_text

    if not output.name.endswith(SUFFIX):
        raise fail(f"--output `{output}` must end with `{SUFFIX}` (how nodes recognise it)")
    check_output_file(output, "--output")
    if models is not None:
        check_output_folder(models, "--models")
    with refused():
        params = params_from_text(param or [])
    loaded = load_target(system, quiet=quiet)
    try:
        compiled = loaded.with_overrides(stop_time=stop_time, params=params).compiled
    except OverrideError as exc:
        raise fail(str(exc), ExitCode.PROBLEMS) from None
    write_compiled(compiled, output)
    placed = place_models(compiled, models) if models is not None else []
    if not quiet:
        typer.echo(f"wrote {output} (content hash {compiled.content_hash[:16]})")
        for path in placed:
            typer.echo(f"model {path.parent.name[:16]}  {path.name}")
