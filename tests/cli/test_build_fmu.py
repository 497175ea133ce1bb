"""``fmionnx build-fmu``: source FMUs become binary FMUs for this machine, or a clear error."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

from fmpy.validation import validate_fmu
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.core.archive import write_deterministic_zip
from tests.conftest import FIXTURES

GAIN = FIXTURES / "fmus" / "Gain"


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["build-fmu", *args], catch_exceptions=False)
    return result.exit_code, result.output


def test_a_source_folder_becomes_a_valid_binary_fmu(tmp_path: Path) -> None:
    out = tmp_path / "Gain.fmu"
    code, output = _invoke(str(GAIN), "-o", str(out))
    assert code == 0, output
    assert f"built {out}" in output.replace("\n", "")
    names = zipfile.ZipFile(out).namelist()
    assert "binaries/linux64/Gain.so" in names
    assert "sources/model.c" in names
    assert validate_fmu(str(out)) == []


def test_a_source_only_fmu_is_rebuilt_beside_itself(tmp_path: Path) -> None:
    source = tmp_path / "Gain.fmu"
    write_deterministic_zip(GAIN, source)
    code, output = _invoke(str(source))
    assert code == 0, output
    built = tmp_path / "Gain.built.fmu"
    assert "binaries/linux64/Gain.so" in zipfile.ZipFile(built).namelist()


def test_a_folder_without_sources_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "NoSources"
    folder.mkdir()
    shutil.copy(GAIN / "modelDescription.xml", folder)
    code, output = _invoke(str(folder), "-o", str(tmp_path / "x.fmu"))
    assert code == 1
    assert "E015" in output
    assert "no sources/ folder" in " ".join(output.split())  # rich wraps long paths
    assert not (tmp_path / "x.fmu").exists()


def test_a_missing_source_is_reported(tmp_path: Path) -> None:
    code, output = _invoke(str(tmp_path / "missing"))
    assert code == 1
    assert "E010" in output
    assert "Traceback" not in output


def test_a_compile_error_shows_the_compiler_log_and_writes_nothing(tmp_path: Path) -> None:
    broken = tmp_path / "Gain"
    shutil.copytree(GAIN, broken)
    model = broken / "sources" / "model.c"
    model.write_text(model.read_text() + "\nthis is not C;\n")
    out = tmp_path / "Gain.fmu"
    code, output = _invoke(str(broken), "-o", str(out))
    assert code == 1
    assert "failed" in output
    assert "error" in output.lower()
    assert "model.c" in output
    assert not out.exists()
    assert not list(tmp_path.glob("*.part"))
