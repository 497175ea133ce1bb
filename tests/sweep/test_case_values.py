"""What a case's record and the study's table hold: infinite metrics as values, NaN as empty
with its reason, a target's column of its variable's type; and a stop time no case may run to
refused when the study is compiled. No cluster: the records are written as the driver does."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.backends.sweep.case import NAN_NOTE, CaseOutcome
from fmionnx.cli import app
from fmionnx.pipeline.sweep import plan_study
from fmionnx.results.study import StudyFolder
from tests.sweep.conftest import WriteStudy

STUDY = """\
fmionnx: 1
system: system.yaml
parameters:
  gain.k: [1, 2, 3]
  run.stop: [1]
metrics: {top: max(gain.y), low: min(gain.y), end: final(gain.y)}
"""


def _folder(write_study: WriteStudy, tmp_path: Path, text: str = STUDY) -> StudyFolder:
    plan, _ = plan_study(write_study(text))
    folder = StudyFolder(tmp_path / "out", plan)
    folder.prepare(resume=False)
    return folder


def test_infinite_metrics_are_values_and_nan_is_empty_with_its_reason(
    write_study: WriteStudy, tmp_path: Path
) -> None:
    folder = _folder(write_study, tmp_path)
    inf, nan = math.inf, math.nan
    fault = "component `gain` at t=0.5 s: failing on purpose"
    folder.record(CaseOutcome("case-0000", "ok", metrics={"top": inf, "low": -inf, "end": 1.5}))
    folder.record(CaseOutcome("case-0001", "ok", metrics={"top": nan, "low": 0.0, "end": nan}))
    folder.record(
        CaseOutcome("case-0002", "fault", fault, metrics={"top": nan, "low": 1, "end": 2})
    )
    # The record is strict JSON (no `Infinity`, no `NaN`), and says why NaN has no value.
    text = (folder.records / "case-0000.json").read_text()
    record = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in a record"))
    assert record["metrics"] == {"top": "inf", "low": "-inf", "end": 1.5}
    record = json.loads((folder.records / "case-0001.json").read_text())
    assert record["metrics"] == {"top": None, "low": 0.0, "end": None}
    assert record["notes"] == {"top": NAN_NOTE, "end": NAN_NOTE}

    table = folder.table()
    folder.write_table(table)
    assert table.column("top")[0] == inf
    assert table.column("low")[0] == -inf
    assert math.isnan(table.column("top")[1])
    assert table.column("message") == [
        "",
        f"end: {NAN_NOTE}; top: {NAN_NOTE}",
        f"{fault}; top: {NAN_NOTE}",  # a fault's own message, and why `top` is empty
    ]
    import pandas as pd

    for read in (
        pd.read_csv(folder.out / "cases.csv"),
        pd.read_parquet(folder.out / "cases.parquet"),
    ):
        assert read["top"].tolist()[0] == inf
        assert read["low"].tolist()[0] == -inf
        assert math.isnan(read["top"].tolist()[1])


def test_a_target_column_has_its_variable_type(write_study: WriteStudy, tmp_path: Path) -> None:
    """``gain.k`` (float64) and ``run.stop`` (seconds) written as integers are floats."""
    folder = _folder(write_study, tmp_path)
    for case in folder.plan.cases:
        folder.record(CaseOutcome(case.id, "ok", metrics={"top": 1.0, "low": 0.0, "end": 1.0}))
    table = folder.table()
    assert table.kind("gain.k") == "float"
    assert table.kind("run.stop") == "float"
    assert table.column("gain.k") == [1.0, 2.0, 3.0]


def _refused(study: Path) -> tuple[list[str], str]:
    """`validate` of a study that must fail: its error lines (the folder left out), and all."""
    result = CliRunner().invoke(
        app, ["validate", str(study)], env={"COLUMNS": "200", "NO_COLOR": "1"}
    )
    assert result.exit_code == 1, result.output
    lines = result.output.splitlines()
    return [line.split("/")[-1] for line in lines if ": error[" in line], result.output


def test_a_stop_time_longer_than_a_case_may_run_is_refused_at_its_place(
    write_study: WriteStudy,
) -> None:
    """Every case failed with advice to pass ``--max-steps``, an option ``sweep`` lacks."""
    study = write_study(STUDY.replace("run.stop: [1]", "run.stop: [1, 1e9]"))
    errors, output = _refused(study)
    assert errors == [
        "study.yaml:5:13: error[E103 study-values]: `run.stop`: run.stop 1e+09 makes the run "
        "1e+11 base steps of 0.01 s, more than the 1e+10 a case may run"
    ]
    assert "--max-steps" not in output


def test_a_system_run_longer_than_a_case_may_run_is_refused_at_the_system(
    write_study: WriteStudy,
) -> None:
    """The system's own stop (no `run.stop` in the study) failed every case the same way."""
    study = write_study(STUDY.replace("  run.stop: [1]\n", ""))
    system = study.parent / "system.yaml"
    system.write_text(
        system.read_text(encoding="utf-8").replace("{stop: 1,", "{stop: 1e9,"), encoding="utf-8"
    )
    errors, _ = _refused(study)
    assert errors == [
        "study.yaml:2:9: error[E103 study-values]: the system's run is 1e+11 base steps of "
        "0.01 s, more than the 1e+10 a case may run"
    ]  # the system file's own long-run warning may name `fmionnx run`'s --max-steps
