"""A null in a study's values is shown as the YAML writes it (``null``, not Python's
``None``), and a list holding one gets one error, at the null: not also the scalar branch's
"Input should be a valid boolean" at the list (a bug hunt)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: s
run: {stop: 1, step: 0.1}
components:
  g: {kind: fmu, path: Gain.fmu}
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A system of a Gain (float parameter ``k``)."""
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "sys.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _errors(folder: Path, axis: str) -> list[str]:
    study = f"fmionnx: 1\nsystem: sys.yaml\nparameters: {{g.k: {axis}}}\n"
    (folder / "study.yaml").write_text(study, encoding="utf-8")
    result = CliRunner().invoke(app, ["validate", "study.yaml"], env={"COLUMNS": "300"})
    assert result.exit_code == 1
    return [line for line in result.output.splitlines() if ": error[" in line]


@pytest.mark.parametrize(
    ("axis", "where"),
    [("[null]", "3:20"), ("[[1, null]]", "3:24"), ("[[null]]", "3:21"), ("[1, [2, null]]", "3:27")],
)
def test_a_null_gets_one_error_that_writes_it_as_yaml_does(
    folder: Path, axis: str, where: str
) -> None:
    errors = _errors(folder, axis)
    assert len(errors) == 1, errors
    assert errors[0].startswith(f"study.yaml:{where}: error[E003 invalid-value]")
    assert errors[0].endswith("(got null)")
    assert "None" not in errors[0]


def test_a_list_where_a_scalar_belongs_is_still_reported(folder: Path) -> None:
    # a list of lists in a list: the innermost list, with nothing wrong inside it, keeps
    # the scalar branch's word (the only one on it)
    errors = _errors(folder, "[[[1]]]")
    assert len(errors) == 1, errors
    assert errors[0].startswith(
        "study.yaml:3:21: error[E003 invalid-value]: `parameters.g.k[0][0]`"
    )
