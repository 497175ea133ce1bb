"""A command line naming a command is parsed by the application narrowed to that command
(fmionnx/cli/invoked.py): the same parsing and messages as the whole application's."""

from __future__ import annotations

import pytest
import typer
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.cli.invoked import narrowed

COMMANDS = sorted(typer.main.get_group(app).commands)


def test_every_command_is_found() -> None:
    assert len(COMMANDS) >= 13
    assert {"run", "validate", "build-fmu", "ros2", "convert", "export"} <= set(COMMANDS)
    for name in COMMANDS:
        one = narrowed(app, ["fmionnx", name])
        assert one is not app
        assert list(typer.main.get_group(one).commands) == [name]


@pytest.mark.parametrize(
    "argv", [["fmionnx"], ["fmionnx", "--version"], ["fmionnx", "rnu", "x.fmu"], ["fmionnx", "-h"]]
)
def test_anything_else_gets_the_whole_application(argv: list[str]) -> None:
    assert narrowed(app, argv) is app


def test_the_application_itself_is_left_whole() -> None:
    before = (list(app.registered_commands), list(app.registered_groups))
    narrowed(app, ["fmionnx", "run"])
    assert (app.registered_commands, app.registered_groups) == before


@pytest.mark.parametrize("name", COMMANDS)
@pytest.mark.parametrize("tail", [["--no-such-option"], [], ["a", "b", "c", "d", "e"]])
def test_usage_errors_read_the_same(name: str, tail: list[str]) -> None:
    args = [name, *tail]
    whole = CliRunner().invoke(app, args, env={"COLUMNS": "100"})
    one = CliRunner().invoke(narrowed(app, ["fmionnx", *args]), args, env={"COLUMNS": "100"})
    assert (one.exit_code, one.output) == (whole.exit_code, whole.output)
    assert whole.exit_code != 0 or tail == []  # the probe does reach a parser's verdict


def test_mistyped_command_still_lists_the_real_ones() -> None:
    result = CliRunner().invoke(narrowed(app, ["fmionnx", "rnu"]), ["rnu"])
    assert result.exit_code == 2
    assert "No such command" in result.output
