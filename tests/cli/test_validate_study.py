"""``fmionnx validate`` checks a study file as ``fmionnx sweep`` compiles it; other commands
given a study file say what it is (E003) instead of calling its keys unknown."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

from typer.testing import CliRunner

from fmionnx.cli import app
from tests.conftest import REPO

STUDY = REPO / "examples" / "sweep-tracker" / "study.yaml"

GAIN_SYSTEM = """fmionnx: 1
name: g
run: {{stop: 0.1, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}}}
"""


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "300"})
    return result.exit_code, result.output


def _study(folder: Path, gain: Path, parameters: str) -> Path:
    (folder / "system.yaml").write_text(GAIN_SYSTEM.format(gain=gain), encoding="utf-8")
    study = folder / "study.yaml"
    study.write_text(f"fmionnx: 1\nsystem: system.yaml\nparameters:\n{parameters}", "utf-8")
    return study


def test_the_example_study_validates() -> None:
    assert _invoke("validate", str(STUDY)) == (0, "no problems in 1 file\n")


def test_a_study_error_is_reported_at_its_place(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    study = _study(tmp_path, fixture_fmu("Gain"), "  gain.kk: [1, 2]\n")
    code, output = _invoke("validate", str(study))
    assert code == 1
    assert f"{study}:4:3: error[E10" in output
    assert "`kk`" in output
    assert "unknown key" not in output  # not read as a system file


def test_errors_of_the_varied_system_point_into_it(tmp_path: Path) -> None:
    study = _study(tmp_path, tmp_path / "missing.fmu", "  gain.k: [1, 2]\n")
    code, output = _invoke("validate", str(study))
    assert code == 1
    assert f"{tmp_path / 'system.yaml'}:5:" in output
    assert "error[E010 file-not-found]" in output
    assert f"{study}:2:9: error[E101 study-system]" in output


def test_a_study_given_to_run_is_named_as_such(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    study = _study(tmp_path, fixture_fmu("Gain"), "  gain.k: [1, 2]\n")
    code, output = _invoke("run", str(study), "--no-out")
    assert code != 0
    assert "error[E003 invalid-value]: `study.yaml` is a study file" in output
    assert "fmionnx sweep study.yaml --out DIR" in output
    assert "unknown key" not in output


def test_junit_skips_the_study_check_for_a_system_and_runs_it_for_a_study(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    study = _study(tmp_path, fixture_fmu("Gain"), "  gain.k: [1, 2]\n")
    code, output = _invoke("validate", "-f", "junit", str(tmp_path / "system.yaml"), str(study))
    assert code == 0, output
    suites = ET.fromstring(output).findall("testsuite")
    outcomes = {
        Path(suite.get("name", "")).name: suite.find("testcase[@name='study']") for suite in suites
    }
    system_case, study_case = outcomes["system.yaml"], outcomes["study.yaml"]
    assert system_case is not None
    assert study_case is not None
    skipped = system_case.find("skipped")
    assert skipped is not None
    assert skipped.get("message") == "not a study file (a system)"
    assert study_case.find("skipped") is None
    assert study_case.find("failure") is None


def test_locked_does_not_ask_a_study_for_a_lock_file(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    study = _study(tmp_path, fixture_fmu("Gain"), "  gain.k: [1, 2]\n")
    code, output = _invoke("validate", "--locked", str(study))
    assert code == 0, output
    assert "E08" not in output  # no lock-file diagnostic (E08x)
    assert "fmionnx.lock" not in output
