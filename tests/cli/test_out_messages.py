"""``--out`` messages say what is wrong with the folder given (a bug hunt): an empty
``--out`` is said to be empty (it was taken for ``.`` and the current folder's files were
blamed), and where a file stands in the way of a folder to be made, that file is named (not
the folder that does not exist). Also the checks table ``run`` prints with its results:
an unnamed check, called by its expression, shows it once."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from tests.conftest import build_fixture_fmu

#: Signals only: runs without any model file.
SYSTEM = """\
fmionnx: 1
name: s
run: {stop: 1, step: 0.5}
components:
  s: {kind: signal, outputs: {x: {constant: 1}}}
checks:
  - expect: max(s.x) > 0
  - {name: named, expect: final(s.x) < 2}
"""
STUDY = "fmionnx: 1\nsystem: gain.yaml\nparameters: {g.k: [1, 2]}\n"
GAIN = "fmionnx: 1\nname: g\nrun: {stop: 1, step: 0.5}\ncomponents:\n  g: {kind: fmu, path: Gain.fmu}\n"


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A system, a study of a Gain FMU, and a plain file ``afile``; the current folder."""
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "sys.yaml").write_text(SYSTEM, encoding="utf-8")
    (tmp_path / "gain.yaml").write_text(GAIN, encoding="utf-8")
    (tmp_path / "study.yaml").write_text(STUDY, encoding="utf-8")
    (tmp_path / "afile").write_text("a file\n", encoding="utf-8")
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "300"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


@pytest.mark.parametrize("command", [["run", "sys.yaml"], ["sweep", "study.yaml"]])
@pytest.mark.parametrize("option", ["--out", "-o"])
def test_an_empty_out_is_said_to_be_empty(folder: Path, command: list[str], option: str) -> None:
    before = sorted(p.name for p in folder.iterdir())
    code, output = _invoke(*command, option, "")
    assert code == 2
    assert "error: --out is empty: name a results folder, e.g. `--out results`" in output
    assert "`.`" not in output
    assert sorted(p.name for p in folder.iterdir()) == before  # nothing written, nothing run


@pytest.mark.parametrize("command", [["run", "sys.yaml"], ["sweep", "study.yaml"]])
def test_a_file_in_the_way_of_out_is_named(folder: Path, command: list[str]) -> None:
    code, output = _invoke(*command, "--out", "afile/sub")
    assert code == 2
    assert "error: --out `afile/sub`: `afile` exists and is not a folder" in output
    assert (folder / "afile").read_text(encoding="utf-8") == "a file\n"


def test_out_naming_a_file_still_names_it(folder: Path) -> None:
    code, output = _invoke("run", "sys.yaml", "--out", "afile")
    assert code == 2
    assert "error: --out `afile` exists and is not a folder" in output


def test_an_unnamed_check_shows_its_expression_once(folder: Path) -> None:
    code, output = _invoke("run", "sys.yaml", "--out", "results")
    assert code == 0, output
    lines = output.splitlines()
    assert sum("max(s.x) > 0" in line for line in lines) == 1
    named = next(i for i, line in enumerate(lines) if "named" in line)
    assert "final(s.x) < 2" in lines[named + 1]  # a named check shows both
