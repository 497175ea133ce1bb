"""Output that is not a terminal is not cut at 80 columns (issue #34).

rich assumes 80 columns where no terminal tells it a width: tables piped to a file or a CI log
were squeezed, their file names cut with ``…``. The consoles of ``fmionnx.cli.console`` lay
out as wide as the content there; an explicit ``COLUMNS`` and a terminal keep their width.
"""

from __future__ import annotations

import pytest
from rich.table import Table

from fmionnx.cli.app import fail
from fmionnx.cli.console import make_console

LONG_NAME = (
    "out/tracker-study/" + "heatmap-distance_to_B-over-cruiseSpeed-and-turnRate" * 2 + ".png"
)


def _table() -> Table:
    table = Table()
    table.add_column("tracker.cruiseSpeed")
    table.add_column("wrote")
    table.add_row("1.5", LONG_NAME)
    return table


def test_a_table_piped_without_columns_is_as_wide_as_its_content(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)
    make_console().print(_table())
    lines = capsys.readouterr().out.splitlines()
    assert any(LONG_NAME in line for line in lines)
    assert any("tracker.cruiseSpeed" in line for line in lines)
    assert "…" not in "".join(lines)
    assert len(lines) == 5  # top, header, rule, one row, bottom: nothing wrapped


def test_an_explicit_columns_is_kept(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    make_console().print(_table())
    lines = capsys.readouterr().out.splitlines()
    assert max(len(line) for line in lines) <= 80
    assert not any(LONG_NAME in line for line in lines)


def test_an_error_is_one_line_whatever_its_length(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """rich broke it at 80 columns, inside a path or a command a user copies."""
    monkeypatch.setenv("COLUMNS", "80")
    fail(f"cannot write `{LONG_NAME}`: run `fmionnx sweep study.yaml --out {LONG_NAME} --force`")
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"--out {LONG_NAME} --force" in err
