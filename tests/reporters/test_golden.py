"""Every format on a real validate call: two system files, errors and warnings in both.

The systems use the diagnostics corpus's shared models (real FMUs built from C, a real ONNX
model). Output is compared with ``golden/two-files.<format>``; the fmionnx version is the only
thing normalised (paths are relative to the working directory already).
Regenerate after an intended change with ``UPDATE_GOLDEN=1 pytest tests/reporters``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import jsonschema
import pytest
from typer.testing import CliRunner

from fmionnx import __version__
from fmionnx.cli.app import app
from fmionnx.reporters import REPORTER_BY_NAME

GOLDEN = Path(__file__).parent / "golden"
SARIF_SCHEMA = json.loads(
    (Path(__file__).parent / "sarif-schema-2.1.0.json").read_text(encoding="utf-8")
)
EXTENSION = {
    "text": "txt",
    "json": "json",
    "github": "github.txt",
    "sarif": "sarif",
    "junit": "xml",
}

FIRST = """\
fmionnx: 1
name: first
run: {stop: 1, step: 0.01}
components:
  net: {kind: onnx, path: ../models/tiny.onnx, period: 0.1}
  gain: {kind: fmu, path: ../models/Gain.fmu}
connections:
  - net.label_out -> gain.u
  - gain.y -> net.n
"""

SECOND = """\
fmionnx: 1
name: second
run: {stop: 1, step: 0.01}
components:
  gain: {kind: fmu, path: ../models/Gain.fmu, parameters: {k: 2}}
  integ: {kind: fmu, path: ../models/Integrator.fmu}
  spare: {kind: fmu, path: ../models/Integrator.fmu}
connections:
  - gain.yy -> integ.u
"""


@pytest.fixture
def workspace(case_models: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "models").symlink_to(case_models)
    (tmp_path / "systems").mkdir()
    (tmp_path / "systems" / "first.yaml").write_text(FIRST, encoding="utf-8")
    (tmp_path / "systems" / "second.yaml").write_text(SECOND, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def test_every_format_has_a_golden_file() -> None:
    assert set(EXTENSION) == set(REPORTER_BY_NAME)


@pytest.mark.parametrize("name", sorted(EXTENSION))
def test_report_of_two_files_matches_golden(name: str, workspace: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["validate", "systems/first.yaml", "systems/second.yaml", "--format", name],
        catch_exceptions=False,
    )
    assert result.exit_code == 1, result.output
    output = result.output.replace(__version__, "<version>")
    assert str(workspace) not in output
    if name == "sarif":
        jsonschema.Draft4Validator(SARIF_SCHEMA).validate(json.loads(result.output))
    golden = GOLDEN / f"two-files.{EXTENSION[name]}"
    if os.environ.get("UPDATE_GOLDEN") == "1":
        golden.write_text(output, encoding="utf-8")
    assert output == golden.read_text(encoding="utf-8")
