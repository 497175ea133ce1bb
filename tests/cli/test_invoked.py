"""A command line is parsed by the application narrowed to what it can reach
(fmionnx/cli/invoked.py): the same parsing, help and messages as the whole application's."""

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


@pytest.mark.parametrize("argv", [["fmionnx", "rnu", "x.fmu"], ["fmionnx", "--out", "run"]])
def test_a_line_that_names_no_command_gets_the_whole_application(argv: list[str]) -> None:
    assert narrowed(app, argv) is app


@pytest.mark.parametrize(
    "args", [[], ["--help"], ["-h"], ["--version"], ["--no-such-option"], ["--help", "--version"]]
)
def test_options_only_read_the_same_with_the_commands_listed_only(args: list[str]) -> None:
    whole = CliRunner().invoke(app, args, env={"COLUMNS": "100"})
    listing = narrowed(app, ["fmionnx", *args])
    assert listing is not app
    one = CliRunner().invoke(listing, args, env={"COLUMNS": "100"})
    assert (one.exit_code, one.output) == (whole.exit_code, whole.output)
    if "-h" in args or "--help" in args or not args:
        assert all(f" {name} " in whole.output for name in COMMANDS)  # the listing itself


@pytest.mark.parametrize("name", COMMANDS)
def test_a_command_s_help_reads_the_same(name: str) -> None:
    whole = CliRunner().invoke(app, [name, "--help"], env={"COLUMNS": "100"})
    one_app = narrowed(app, ["fmionnx", name, "--help"])
    one = CliRunner().invoke(one_app, [name, "--help"], env={"COLUMNS": "100"})
    assert whole.exit_code == 0
    assert one.output == whole.output


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
