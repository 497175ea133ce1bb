"""An unpacked FMU folder named by a relative path runs, in-process and isolated: fmpy
changes the working folder before it loads the library, which a relative folder did not
survive ("its shared library does not load")."""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: folder
run: {stop: 0.5, step: 0.1}
components:
  v: {kind: fmu, path: Vector3, parameters: {u: [1, 2, 3]}}
"""


@pytest.mark.parametrize("isolate", ["none", "fmus"])
def test_a_relative_fmu_folder_runs(
    isolate: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with zipfile.ZipFile(build_fixture_fmu("Vector3")) as archive:
        archive.extractall(tmp_path / "Vector3")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(
        app, ["run", "-q", "system.yaml", "--isolate", isolate, "--out", "out"],
        catch_exceptions=False,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    with (tmp_path / "out" / "results.csv").open(encoding="utf-8") as stream:
        last = list(csv.DictReader(stream))[-1]
    assert [float(last[f"v.y[{i}]"]) for i in range(3)] == [2.0, 4.0, 6.0]
