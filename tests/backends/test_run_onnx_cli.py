"""``fmionnx run MODEL.onnx --input name=file.npy``: one inference through the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import built_model


@pytest.fixture
def frame(tmp_path: Path) -> Path:
    image = np.zeros((1, 480, 640, 3), np.uint8)
    image[0, 100:200, 300:340] = (0, 0, 255)  # a blue board, columns 300..339
    path = tmp_path / "frame.npy"
    np.save(path, image)
    return path


def test_one_inference_prints_and_saves_the_outputs(frame: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app,
        [
            "run",
            str(built_model("sign_detector.onnx")),
            "--input",
            f"image={frame}",
            "--out",
            str(out),
        ],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    assert result.output.rstrip().endswith(f"Results: {out}")
    blob_x = np.load(out / "blobX.npy")
    blob_size = np.load(out / "blobSize.npy")
    np.testing.assert_array_equal(blob_x, np.array([[-1.0, -1.0, 319.5]], np.float32))
    assert blob_size[0, 2] == pytest.approx(np.sqrt(2 * 100 * 40))
    assert blob_size[0, 0] == 0.0


def test_an_unknown_input_name_is_an_error_with_a_suggestion(frame: Path) -> None:
    result = CliRunner().invoke(
        app, ["run", str(built_model("sign_detector.onnx")), "--input", f"imag={frame}"]
    )
    assert result.exit_code != 0
    assert "did you mean `image`?" in result.output
    assert "Traceback" not in result.output


def test_an_unreadable_input_file_is_an_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        ["run", str(built_model("sign_detector.onnx")), "--input", f"image={tmp_path / 'no.npy'}"],
    )
    assert result.exit_code != 0
    assert "cannot read" in result.output
    assert "Traceback" not in result.output
