"""The ``fmionnx`` console script: a Ctrl-C while the command line loads ends in one line.

Before any command can catch a stop, ``fmionnx.cli`` imports every command's module, typer
and rich (about a tenth of a second): a Ctrl-C in that window printed Python's
``KeyboardInterrupt`` traceback, and one during the command's own start too. Here only the
standard library is loaded before the command line, and a stop that reaches this far is
said in one line with the signal's exit status.
"""

from __future__ import annotations

import sys


def console() -> None:
    """The console script's entry point: :func:`fmionnx.cli.console`, a stop said plainly."""
    try:
        from fmionnx.cli import console as command_line

        command_line()
    except KeyboardInterrupt as stop:
        from fmionnx.runtime.stopping import exit_code, stop_reason

        reason = stop_reason(stop)
        try:
            print(f"error: interrupted by {reason}", file=sys.stderr)
        finally:
            sys.exit(exit_code(reason))
