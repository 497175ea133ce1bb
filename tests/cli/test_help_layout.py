"""How ``--help`` reads (issue #34): no ``<bool>`` after a flag, sentences not broken where the
docstring's lines happened to end."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.cli.helptext import unwrapped


def _help(*command: str, columns: int = 100) -> str:
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": str(columns)})
    assert result.exit_code == 0, result.output
    return result.output


@pytest.mark.parametrize(
    "command",
    [(), ("validate",), ("run",), ("sweep",), ("node",), ("ros2",), ("ros2", "graph")],
)
def test_flags_show_no_type_placeholder(command: tuple[str, ...]) -> None:
    text = _help(*command)
    assert "<bool>" not in text
    assert "Show this message and exit." in text


def test_options_that_take_a_value_keep_their_placeholder() -> None:
    text = _help("run")
    assert "<path>" in text
    assert "<float>" in text


def test_a_docstring_paragraph_is_wrapped_by_the_terminal_not_by_its_source_lines() -> None:
    lines = [line.strip(" │") for line in _help("run", columns=200).splitlines()]
    # the docstring breaks its line after "A fault"; the help must not
    assert any("names the folder. A fault or a failed check exits 1" in line for line in lines)


def test_unwrapped_joins_prose_and_keeps_examples_and_lists() -> None:
    text = (
        "First line\ncontinues here.\n\n  fmionnx run a.yaml\n  fmionnx run b.yaml\n\n- one\n- two"
    )
    assert unwrapped(text) == (
        "First line continues here.\n\n  fmionnx run a.yaml\n  fmionnx run b.yaml\n\n- one\n- two"
    )
