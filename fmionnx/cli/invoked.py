"""The application narrowed to what the command line can reach.

Typer turns every registered command's parameters into click's at each start, ``--help`` or
not: about 15 ms for fmionnx's thirteen commands and ~130 options, of which ``run`` alone
takes 5. Two command lines need less:

* one that names a command (``fmionnx run model.fmu``, ``fmionnx run --help``) is parsed by
  an application holding that command only: the same callback, options and settings, so the
  same parsing, values, help and error messages;
* one of options only (``fmionnx --help``, a bare ``fmionnx``, ``--version``) never runs a
  command: its help lists each command's name and summary, which the commands' stand-ins
  below carry without their parameters.

Anything else (a mistyped command, which deserves the list of the real ones) gets the whole
application. ``tests/cli/test_invoked.py`` compares the outputs with the whole application's.
"""

from __future__ import annotations

import copy

import typer
from typer.main import get_command_name
from typer.models import CommandInfo


def narrowed(app: typer.Typer, argv: list[str]) -> typer.Typer:
    """``app`` with only the command or command group ``argv[1]`` names; for options only,
    ``app`` listing its commands without their parameters; else ``app``."""
    if all(arg.startswith("-") for arg in argv[1:]):
        return _listing(app)
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


def _listing(app: typer.Typer) -> typer.Typer:
    """``app`` whose commands are stand-ins: same names, help and panels, no parameters.

    Only for a command line that cannot run a command: a stand-in's callback does nothing.
    """
    listed = copy.copy(app)
    listed.registered_commands = [_stand_in(info) for info in app.registered_commands]
    return listed


def _stand_in(info: CommandInfo) -> CommandInfo:
    callback = info.callback
    if callback is None:
        return info

    def listed() -> None:
        """Never called: a stand-in for the listing."""

    listed.__name__ = callback.__name__
    listed.__doc__ = callback.__doc__
    stand_in = copy.copy(info)
    stand_in.callback = listed
    return stand_in
