"""Help texts say what each option does in each mode (issue #16).

``run`` is the entry of the in-process backend, of the ROS 2 backend and of single models;
an option that only applies to one of them says which, and ``--param`` shows both the system
form (``component.name=value``) and the single-FMU form (``name=value``).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app


def help_text(*command: str) -> str:
    """The help of ``fmionnx COMMAND``, one line, box drawing removed."""
    result = CliRunner().invoke(app, [*command, "--help"], env={"COLUMNS": "400"})
    assert result.exit_code == 0
    return " ".join(result.output.replace("│", " ").split())


@pytest.mark.parametrize(
    "phrase",
    [
        "Run a system in-process or as ROS 2 nodes (--backend ros2), or a single FMU / ONNX model.",
        "Results go to --out, by default out/<system name>/; the last line names the folder.",
        "A system: `component.name=value` (`-p tracker.turnRate=0.6`); a single FMU: "
        "`name=value` (`-p k=2`).",
        "(default: out/<system name>/)",
        "Write no results at all",
        "In-process: camera frames and the recorded signals; with --backend ros2: every topic",
        "Base (communication) step in seconds; replaces `run.step`",
        "Seconds between two rows of results.csv",
        "Single FMU only: `cs` (co-simulation) or `me` (model exchange)",
        "Single ONNX model only: `name=file.npy` per input",
        "`ros2`: one ROS 2 node process per component, from the same system file",
        "With --backend ros2: `lockstep` (reproducible) or `free` (paced).",
        "With --backend ros2 --sync free: the simulator's pace (default 1).",
        "In-process: every base step waits for its moment;",
        "Show the run live: `rerun` (spawns a Rerun viewer, or connects to the local one)",
        "Write the run as a Rerun recording (.rrd) without a viewer",
        "Time every component's phases",
        "`warn` (noted once per connection, passed on)",
        "Seconds one step of a component may take before the run stops with a fault",
        "`fmus` (every FMU), `all`, `none`, or component names",
        "Default: `guardian` for a lone FMU (on Linux, without --sandbox, --record, --view or "
        "--rrd), else `fmus`",
        "Write into a results folder (--out or the default)",
        "fmionnx run model.fmu -p k=2",
    ],
)
def test_run_help_says_which_mode_an_option_serves(phrase: str) -> None:
    assert phrase in help_text("run")


def test_run_help_no_longer_calls_itself_in_process_only() -> None:
    assert "Run a system in-process;" not in help_text("run")


def test_validate_help_names_single_models() -> None:
    text = help_text("validate")
    assert "or single models (.fmu, .onnx, MuJoCo .xml, signal .csv) checked alone" in text
    assert "System files only: a single model or a study has no lock" in text


def test_a_single_fmu_takes_bare_parameter_names_as_the_help_says(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["run", "Gain.fmu", "-q", "-p", "k=3", "-p", "u=1"])
    assert result.exit_code == 0, result.output
    last = (tmp_path / "out" / "Gain" / "results.csv").read_text(encoding="utf-8").splitlines()[-1]
    assert last.split(",")[1] == "3"  # y = k * u
