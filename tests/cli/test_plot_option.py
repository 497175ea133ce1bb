"""``fmionnx run --plot``: signals.png for any run, a lone FMU included, listed in run.json."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.results.signals_plot import draw_signals, signal_series


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["run", *args], env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


@pytest.fixture
def gain(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    return Path(shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu"))


def test_a_single_fmu_run_with_plot_writes_signals_png(gain: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    code, output = run(str(gain), "--plot", "--out", str(out), "--quiet")
    assert code == 0, output
    assert (out / "signals.png").read_bytes().startswith(b"\x89PNG")
    files = json.loads((out / "run.json").read_text(encoding="utf-8"))["files"]
    assert "signals.png" in files


def test_a_single_fmus_panels_are_its_variables_with_units(gain: Path) -> None:
    system = fmionnx.load(gain)
    result = system.run(isolate="none")
    series = signal_series(result, system.compiled, system.aliases)
    assert [(s.signal, s.unit) for s in series] == [("y", "m"), ("w", "m")]
    assert series[1].columns == ("w[1]", "w[2]", "w[3]")  # FMI 2 scalar names, as in the CSV
    figure = draw_signals(series, result, title="Gain")
    assert [a.get_ylabel() for a in figure.axes] == ["y [m]", "w [m]"]
    np.testing.assert_array_equal(figure.axes[0].lines[0].get_ydata(), result.signals["y"])


def test_without_plot_no_signals_png(gain: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert run(str(gain), "--out", str(out), "--quiet")[0] == 0
    assert not (out / "signals.png").exists()


@pytest.mark.parametrize("extra", [["--no-out"], []])
def test_plot_needs_a_results_folder_of_signals(
    gain: Path, tmp_path: Path, extra: list[str]
) -> None:
    target = str(gain) if extra else str(tmp_path / "model.onnx")
    code, output = run(target, "--plot", *extra)
    assert code == 2
    assert "--plot" in output
    assert "Traceback" not in output
