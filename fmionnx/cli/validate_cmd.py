"""``fmionnx validate``: check system files, or single model files, like a compiler."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app


def _check_format(value: str) -> str:
    from fmionnx.reporters import REPORTER_BY_NAME

    if value not in REPORTER_BY_NAME:
        names = ", ".join(sorted(REPORTER_BY_NAME))
        msg = f"unknown format `{value}`; expected one of {names}"
        raise typer.BadParameter(msg)
    return value


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx validate systems/sign_follower.yaml\n\n"
    "  fmionnx validate systems/*.yaml --format json > report.json\n\n"
    "  fmionnx validate build/models/ReadOdometry.fmu build/models/sign_detector.onnx\n\n"
    "  fmionnx validate examples/sweep-tracker/study.yaml\n\n"
    "  fmionnx validate --locked --format github systems/*.yaml   # in CI",
)
def validate(
    systems: Annotated[
        list[Path],
        typer.Argument(
            help="System files (.yaml, .ssp, .ssd), study files (checked as `fmionnx sweep` "
            "compiles them), or single models (.fmu, .onnx, MuJoCo .xml, signal .csv) checked "
            "alone.",
            metavar="FILES...",
        ),
    ],
    output_format: Annotated[
        str,
        typer.Option(
            "--format",
            "-f",
            callback=_check_format,
            help="Report format: text, json, github, sarif, junit.",
        ),
    ] = "text",
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Report errors only.")] = False,
    locked: Annotated[
        bool,
        typer.Option(
            "--locked",
            help="Also fail when a model's interface differs from `<system>.fmionnx.lock` "
            "(written by `fmionnx lock`). System files only: a single model or a study has "
            "no lock (lock the system a study varies).",
        ),
    ] = False,
) -> None:
    """Check system files and the models they use, study files, or single models; exit 1 on
    any error.

    A single model is compiled as `fmionnx run` would, then checked deeper: FMPy's validation
    and the binary of an FMU, the ONNX checker and shape inference, MuJoCo's scene compiler.
    """
    from fmionnx import api
    from fmionnx.core.diagnostics import Diagnostic, Severity
    from fmionnx.pipeline.system import check_if_study, compiled_before
    from fmionnx.reporters import REPORTER_BY_NAME, FileResult

    results = []
    for path in systems:
        model = api.is_model_file(path)
        # A system or a study compiled before and unchanged since is read back without
        # parsing (and without telling one from the other first: their entries differ).
        result = None if model else compiled_before(path)
        study = False
        if result is None and not model:
            result = check_if_study(path)
            study = result is not None
        if model:
            result = api.check_model(path)
        elif result is None:
            result = api.compile_system(path)
        diagnostics = result.diagnostics
        if locked and not model and not study:
            from fmionnx.lock.check import check_lock  # the lock's reader: only when asked

            merged = [*diagnostics, *check_lock(path)]
            diagnostics = tuple(sorted(dict.fromkeys(merged), key=Diagnostic.sort_key))
        if quiet:
            diagnostics = tuple(d for d in diagnostics if d.severity is Severity.ERROR)
        document = "model" if model else "study" if study else "system"
        results.append(FileResult(path, diagnostics, locked=locked, document=document))
    reporter = REPORTER_BY_NAME[output_format]
    reporter.render(results, sys.stdout, color=sys.stdout.isatty())
    worst = max((r.worst for r in results if r.worst is not None), default=None)
    raise typer.Exit(ExitCode.PROBLEMS if worst is Severity.ERROR else ExitCode.OK)
