"""Command-line interface. Commands live in one module each and are registered here."""

from __future__ import annotations

import sys

from fmionnx.cli import (  # noqa: F401 - importing registers the commands (invoked, lean_help aside)
    build_cmd,
    compile_cmd,
    graph_cmd,
    inspect_cmd,
    invoked,
    lean_help,
    lock_cmd,
    lsp_cmd,
    node_cmd,
    ros2_cmd,
    run_cmd,
    schema_cmd,
    ssp_cmd,
    sweep_cmd,
    validate_cmd,
)
from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.helptext import tidy

tidy(app)  # every command is registered now: plain flags, help paragraphs unwrapped


def main() -> None:
    """Console-script entry point.

    Commands check the paths they are given; this is the net below them, so that a file system
    refusing (a full disk, a path that vanished) ends with one line, not a traceback.
    """
    if lean_help.wants_help(sys.argv):
        lean_help.prepare()
    try:
        invoked.narrowed(app, sys.argv)()
    except BrokenPipeError:  # `fmionnx graph ... | head`: the reader left; nothing to say
        sys.stderr.close()
        sys.exit(ExitCode.PROBLEMS)
    except OSError as exc:
        where = f": `{exc.filename}`" if exc.filename else ""
        print(f"error: {exc.strerror or exc}{where}", file=sys.stderr)
        sys.exit(ExitCode.PROBLEMS)
