"""``fmionnx schema``: print or write the JSON Schema of system files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import app
from fmionnx.cli.outputs import check_output_file, write_derived


def schema_text(*, study: bool = False) -> str:
    """The schema as written to ``schemas/system.schema.json`` (``study.schema.json``)."""
    if study:
        from fmionnx.spec.study import json_schema as study_schema

        return json.dumps(study_schema(), indent=2, sort_keys=True) + "\n"
    from fmionnx.spec.model import json_schema

    return json.dumps(json_schema(), indent=2, sort_keys=True) + "\n"


@app.command(epilog="Example:\n\n  fmionnx schema -o schemas/system.schema.json")
def schema(
    output: Annotated[Path | None, typer.Option("--output", "-o", help="File to write.")] = None,
    study: Annotated[
        bool, typer.Option("--study", help="The schema of study files (`fmionnx sweep`).")
    ] = False,
) -> None:
    """Print the JSON Schema of system files (for editor completion and checks)."""
    text = schema_text(study=study)
    if output is None:
        typer.echo(text, nl=False)
    else:
        write_derived(check_output_file(output, "--output"), text)
