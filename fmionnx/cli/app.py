"""The typer application and options shared by several commands."""

from __future__ import annotations

import enum
from typing import Annotated

import typer

app = typer.Typer(
    name="fmionnx",
    help="Compile, check and run systems of FMUs, ONNX models and MuJoCo scenes.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode="rich",
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


class ExitCode(enum.IntEnum):
    """Process exit codes: 0 ok, 1 the system or its models are wrong, 2 usage."""

    OK = 0
    PROBLEMS = 1
    USAGE = 2


QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="Print only errors.")]


def fail(message: str, code: int = ExitCode.USAGE) -> typer.Exit:
    """Print ``error: message`` on stderr and return the Exit to raise (usage error by default)."""
    from rich.console import Console

    Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {message}")
    return typer.Exit(code)
