"""The application narrowed to the command the command line names.

Typer turns every registered command's parameters into click's at each start, ``--help`` or
not: about 15 ms for fmionnx's thirteen commands and ~130 options, of which ``run`` alone
takes 5. A command line that names a command (``fmionnx run model.fmu``) is parsed by an
application holding that command only: the same callback, options and settings, so the
same parsing, values and error messages. Anything else (help, ``--version``, a mistyped
command that deserves the list of the real ones) gets the whole application.
``tests/cli/test_invoked.py`` compares the two on every command.
"""

from __future__ import annotations

import copy

import typer
from typer.main import get_command_name


def narrowed(app: typer.Typer, argv: list[str]) -> typer.Typer:
    """``app`` with only the command or command group ``argv[1]`` names, else ``app``."""
    if len(argv) < 2:
        return app
    name = argv[1]
    commands = [
        c
        for c in app.registered_commands
        if c.callback is not None and (c.name or get_command_name(c.callback.__name__)) == name
    ]
    groups = [g for g in app.registered_groups if g.name == name]
    if len(commands) + len(groups) != 1:
        return app
    one = copy.copy(app)  # the settings and the callback shared; the lists are new ones
    one.registered_commands = commands
    one.registered_groups = groups
    return one
