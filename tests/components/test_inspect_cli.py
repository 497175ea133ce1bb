"""``fmionnx inspect``: text and JSON output, kind detection, errors without tracebacks."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import REPO

GOLDEN = Path(__file__).resolve().parent / "golden"
runner = CliRunner()


@pytest.fixture(autouse=True)
def _in_repo(monkeypatch: pytest.MonkeyPatch) -> None:
    """Relative paths in the output, as a user in the repository would see them."""
    monkeypatch.chdir(REPO)


def _json(args: list[str]) -> dict:
    result = runner.invoke(app, ["inspect", *args, "--format", "json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert re.fullmatch(r"[0-9a-f]{64}", data["content_hash"])
    data["content_hash"] = "<sha256>"  # changes with every edit of the fixture sources
    return data


@pytest.mark.parametrize(
    ("golden", "path"),
    [
        ("inspect-gain.json", "tests/fixtures/fmus/Gain"),
        ("inspect-vector3.json", "tests/fixtures/fmus/Vector3/modelDescription.xml"),
        ("inspect-rover.json", "tests/fixtures/scenes/rover.xml"),
    ],
)
def test_json_output_matches_golden(golden: str, path: str) -> None:
    data = _json([path])
    expected_file = GOLDEN / golden
    if os.environ.get("FMIONNX_UPDATE_GOLDEN"):
        expected_file.write_text(json.dumps(data, indent=2) + "\n")
    assert data == json.loads(expected_file.read_text())


def test_json_output_of_onnx_model(onnx_models: dict[str, Path]) -> None:
    data = _json([str(onnx_models["dynamic"])])
    assert data["kind"] == "onnx"
    assert [(p["name"], p["shape"]) for p in data["ports"]] == [
        ("image", ["batch", "?", 640, 3]),
        ("count", []),
        ("pixels", ["batch", "?", 640, 3]),
        ("same", []),
    ]


def test_text_output_has_facts_and_a_plain_port_table() -> None:
    result = runner.invoke(app, ["inspect", "tests/fixtures/fmus/Gain"], catch_exceptions=False)
    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    assert lines[0] == "fmu: tests/fixtures/fmus/Gain"
    assert re.search(r"^  fmiVersion +2\.0$", result.stdout, re.MULTILINE)
    assert re.search(r"^  interfaceTypes +cs,me$", result.stdout, re.MULTILINE)
    header = next(i for i, line in enumerate(lines) if line.startswith("NAME"))
    assert lines[header].split() == [
        "NAME", "CAUSALITY", "TYPE", "SHAPE", "UNIT", "START", "DESCRIPTION"
    ]  # fmt: skip
    rows = [re.split(r"\s{2,}", line) for line in lines[header + 1 :]]
    assert rows == [
        ["u", "input", "float64", "scalar", "m", "0", "Input signal"],
        ["k", "parameter", "float64", "scalar", "2", "Gain"],
        ["y", "output", "float64", "scalar", "m", "k*u"],
        ["v", "input", "float64", "[3]", "m", "[0, 0, 0]", "Input vector"],
        ["w", "output", "float64", "[3]", "m", "k*v"],
    ]
    assert "\x1b[" not in result.stdout


def test_the_range_column_shows_the_declared_bounds(fixture_fmu) -> None:
    result = runner.invoke(app, ["inspect", str(fixture_fmu("Faulty"))], catch_exceptions=False)
    assert result.exit_code == 0
    (mode,) = [line for line in result.stdout.splitlines() if line.startswith("mode ")]
    assert re.split(r"\s{2,}", mode)[:6] == ["mode", "parameter", "int32", "scalar", "0", "0..14"]
    as_json = runner.invoke(app, ["inspect", str(fixture_fmu("Faulty")), "--format", "json"])
    ports = {p["name"]: p for p in json.loads(as_json.stdout)["ports"]}
    assert (ports["mode"]["min"], ports["mode"]["max"]) == (0, 14)
    assert (ports["u"]["min"], ports["u"]["max"]) == (None, None)


def test_unknown_file_kind_is_one_error_paragraph() -> None:
    result = runner.invoke(app, ["inspect", "README.md"])
    assert result.exit_code == 1
    assert result.stdout == ""
    assert result.stderr.startswith("error[E014]: cannot tell what kind of model `README.md` is")
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(
    ("name", "content", "code"),
    [("broken.fmu", b"not a zip", "E012"), ("broken.onnx", b"\xff\xff garbage", "E012")],
)
def test_model_error_exits_1_with_code(
    tmp_path: Path, name: str, content: bytes, code: str
) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    result = runner.invoke(app, ["inspect", str(path)])
    assert result.exit_code == 1
    assert result.stderr.startswith(f"error[{code}]: ")
    assert "Traceback" not in result.stderr


def test_missing_file_is_e010() -> None:
    result = runner.invoke(app, ["inspect", "no/such/model"])
    assert result.exit_code == 1
    assert result.stderr.startswith("error[E010]: `no/such/model` does not exist")


def test_unknown_format_is_a_usage_error() -> None:
    result = runner.invoke(app, ["inspect", "tests/fixtures/fmus/Gain", "--format", "yaml"])
    assert result.exit_code == 2


def test_help_shows_examples() -> None:
    result = runner.invoke(app, ["inspect", "--help"])
    assert result.exit_code == 0
    assert "sign_detector.onnx --format json" in result.stdout
