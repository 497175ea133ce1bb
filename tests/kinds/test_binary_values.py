"""Binary parameter values (a bug hunt): `-p blob=0c0d` on an FMI 3 `<Binary>` parameter ended
in a traceback (`KeyError: <DType.BINARY: 'binary'>`) and exit status 70.

A binary value is hexadecimal text, as FMI 3 writes binary start values, set once at setup
with fmi3SetBinary. ``Binary3`` is a real FMI 3 FMU built from C whose outputs say which
bytes its parameter holds: ``blobSize`` and ``blobValue`` (the first eight, big-endian).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.pipeline.errors import RequestError
from fmionnx.runtime.result import RunStatus
from tests.conftest import build_fixture_fmu


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def _system(folder: Path, blob: str) -> Path:
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: blobs\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {build_fixture_fmu('Binary3')}, parameters: {{blob: {blob}}}}}\n",
        encoding="utf-8",
    )
    return path


@pytest.mark.parametrize("isolate", ["none", "fmus"])
def test_a_binary_parameter_reaches_the_model_byte_for_byte(folder: Path, isolate: str) -> None:
    outcome = fmionnx.run(
        build_fixture_fmu("Binary3"),
        no_out=True,
        isolate=isolate,
        params={"blob": "0102030405060708ff"},
    )
    result = outcome.result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["blobSize"][-1] == 9
    assert int(result.signals["blobValue"][-1]) == 0x0102030405060708


def test_a_binary_parameter_in_the_system_file(folder: Path) -> None:
    result = fmionnx.run(_system(folder, '"0c0d"'), no_out=True, isolate="none").result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["a.blobValue"][-1] == 0x0C0D


def test_a_binary_value_that_is_not_hexadecimal_is_refused_where_it_is_written(
    folder: Path,
) -> None:
    _system(folder, '"0c0"')
    result = CliRunner().invoke(app, ["validate", "system.yaml"])
    assert result.exit_code != 0
    assert "system.yaml:5:" in result.output
    assert "error[E043 parameter-value]: `a.blob` is of type binary" in result.output
    assert "hexadecimal" in result.output


def test_a_command_line_value_that_is_not_hexadecimal_is_refused_before_the_run(
    folder: Path,
) -> None:
    with pytest.raises(RequestError, match=r"--param `blob`: `zz` is not hexadecimal text"):
        fmionnx.run(
            build_fixture_fmu("Binary3"), no_out=True, isolate="none", params={"blob": "zz"}
        )
