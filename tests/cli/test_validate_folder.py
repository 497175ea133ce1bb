"""``fmionnx validate .`` names the folder it was given (issue #34: it said "`` is not a
system file", the empty name of ``.``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app


@pytest.mark.parametrize("given", [".", "systems"])
def test_a_folder_is_named_as_given_with_a_hint(
    given: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "systems").mkdir()
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["validate", given], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    first, hint = result.output.splitlines()[:2]
    assert first == f"{given}: error[E011 not-a-file]: `{given}` is a folder, not a system file"
    expected = "*.yaml" if given == "." else f"{given}/*.yaml"
    assert hint.strip().endswith(f"e.g. `{expected}`")
    assert "``" not in result.output


def test_a_file_of_another_kind_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "notes.txt").write_text("hello\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["validate", "notes.txt"], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    assert "`notes.txt` is not a system file fmionnx reads" in result.output
