"""The diagnostics corpus: every case folder is one system file and its golden output.

``invalid/<case>/system.yaml`` must fail validation with exactly ``expected.txt`` (exit 1);
``valid/<case>/system.yaml`` must pass (exit 0) and match its ``expected.txt`` when present.
Regenerate goldens after an intended change with ``UPDATE_GOLDEN=1 pytest tests/cases``.
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.core.diagnostics import CODES

CASES = Path(__file__).resolve().parent
INVALID = sorted(p.name for p in (CASES / "invalid").iterdir() if p.is_dir())
VALID = sorted(p.name for p in (CASES / "valid").iterdir() if p.is_dir())

#: Codes whose triggers live in other test suites (they need SSP files, ROS 2 sections or
#: lock files rather than a plain system file; E019 is found by validating a lone model; E024
#: needs a compiled library that lacks functions, built in tests/components/test_fmu_exports.py).
#: E10x-E11x are study-file codes (`fmionnx sweep`), tested in tests/sweep.
COVERED_ELSEWHERE = {"E019", "E024", "E050"} | {
    c for c in CODES if c[1:3] in {"06", "07", "08", "10", "11"}
}


def _validate(
    case_dir: Path, models: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> tuple[int, str]:
    work = tmp_path / case_dir.name
    shutil.copytree(case_dir, work)
    for model in models.iterdir():
        if not model.name.startswith(".") and not (work / model.name).exists():
            (work / model.name).symlink_to(model)
    monkeypatch.chdir(work)
    monkeypatch.setenv("COLUMNS", "200")
    result = CliRunner().invoke(app, ["validate", "system.yaml"], catch_exceptions=False)
    return result.exit_code, result.output


def _check_golden(case_dir: Path, output: str) -> None:
    golden = case_dir / "expected.txt"
    if os.environ.get("UPDATE_GOLDEN") == "1":
        golden.write_text(output, encoding="utf-8")
    assert golden.exists(), f"{golden} is missing (UPDATE_GOLDEN=1 writes it)"
    assert output == golden.read_text(encoding="utf-8")


@pytest.mark.parametrize("case", INVALID)
def test_invalid_case_reports_its_golden_diagnostics(
    case: str, case_models: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    exit_code, output = _validate(CASES / "invalid" / case, case_models, tmp_path, monkeypatch)
    assert "Traceback" not in output
    assert exit_code == 1, output
    _check_golden(CASES / "invalid" / case, output)


@pytest.mark.parametrize("case", VALID)
def test_valid_case_passes(
    case: str, case_models: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    exit_code, output = _validate(CASES / "valid" / case, case_models, tmp_path, monkeypatch)
    assert exit_code == 0, output
    if (CASES / "valid" / case / "expected.txt").exists() or os.environ.get("UPDATE_GOLDEN"):
        _check_golden(CASES / "valid" / case, output)


def test_corpus_triggers_every_code_it_owns() -> None:
    seen: set[str] = set()
    for folder in ("invalid", "valid"):
        for golden in (CASES / folder).glob("*/expected.txt"):
            seen |= set(
                re.findall(
                    r"(?:error|warning|info)\[([EWI]\d{3}) ", golden.read_text(encoding="utf-8")
                )
            )
    missing = set(CODES) - COVERED_ELSEWHERE - seen
    assert not missing, f"add a corpus case for {sorted(missing)}"
