"""The typer application and options shared by several commands."""

from __future__ import annotations

import contextlib
import enum
from collections.abc import Iterator
from typing import Annotated

import typer

from fmionnx.cli.helptext import PlainFlagsGroup

app = typer.Typer(
    name="fmionnx",
    cls=PlainFlagsGroup,
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


def installed_version() -> str:
    """fmionnx's version from the installed package's metadata (what pip and bug reports see).

    A source tree used without installing has no metadata: then the package's own
    ``__version__`` (a test keeps the two equal).
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fmionnx")
    except PackageNotFoundError:
        from fmionnx import __version__

        return __version__


def _print_version(value: bool) -> None:
    if value:
        print(f"fmionnx {installed_version()}")
        raise typer.Exit(ExitCode.OK)


@app.callback()
def _application(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_print_version,
            is_eager=True,
            help="Print fmionnx's version and exit.",
        ),
    ] = False,
) -> None:
    """Compile, check and run systems of FMUs, ONNX models and MuJoCo scenes."""


QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="Print only errors.")]


def fail(message: str, code: int = ExitCode.USAGE) -> typer.Exit:
    """Print ``error: message`` on stderr and return the Exit to raise (usage error by default).

    ``message`` is plain text, printed as written: square brackets in it (``'.[rclpy]'``,
    ``power[0]``, a file name) are not rich markup and must not be eaten as such. It is one
    line that rich never breaks (the terminal wraps it), so a command or a path in it can be
    copied whole.
    """
    from rich.markup import escape

    from fmionnx.cli.console import make_console
    from fmionnx.core.printable import printable

    # printable: a message may quote a file's name or a model's port (terminal escapes);
    # its own line breaks (a fault's several lines) stay
    text = escape("\n".join(printable(line) for line in message.split("\n")))
    make_console(stderr=True, soft_wrap=True).print(f"[bold red]error:[/] {text}")
    return typer.Exit(code)


@contextlib.contextmanager
def refused() -> Iterator[None]:
    """A run pipeline refusal (:class:`~fmionnx.pipeline.errors.PipelineError`) inside becomes
    ``error: message`` on stderr and its exit status."""
    from fmionnx.pipeline.errors import PipelineError

    try:
        yield
    except PipelineError as exc:
        raise fail(str(exc), exc.exit_status) from None
