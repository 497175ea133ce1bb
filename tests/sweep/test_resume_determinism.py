"""Same study, same table; an interrupted study resumes without re-running finished cases;
``--keep-results`` keeps each case's results.csv. One shared local cluster (2 workers)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

from fmionnx.pipeline.sweep import plan_study, run_sweep
from fmionnx.results.study import VOLATILE, StudyFolderError
from tests.sweep.conftest import WriteStudy

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector
#: (a ResourceWarning raised while collecting, so not attributable to a line of ours).
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


SAMPLED = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2]
  integ.x0: {latin_hypercube: {low: -1, high: 1}}
  run.stop: {random: {low: 0.2, high: 0.9}}
sampling: {samples: 3, seed: 7}
metrics:
  y_end: final(gain.y)
"""


def _stable(table: pd.DataFrame) -> pd.DataFrame:
    return table.drop(columns=list(VOLATILE))


def test_same_study_twice_gives_the_same_table(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    study = write_study(
        SAMPLED.replace("run.stop: {random: {low: 0.2, high: 0.9}}", "run.output_interval: [0.02]")
    )
    first = run_sweep(plan_study(study)[0], tmp_path / "a", scheduler=cluster).table
    second = run_sweep(plan_study(study)[0], tmp_path / "b", scheduler=cluster).table
    assert len(first) == 6
    pd.testing.assert_frame_equal(_stable(first), _stable(second))
    assert (tmp_path / "a" / "cases.csv").read_text().splitlines()[0] == (
        "case,gain.k,integ.x0,run.output_interval,y_end,check: small,status,message,wall_time,worker"
    )
    x0 = sorted(first["integ.x0"].unique())
    assert len(x0) == 3  # one Latin-hypercube stratum each: [-1, -1/3), [-1/3, 1/3), [1/3, 1)
    assert [int((v + 1) // (2 / 3)) for v in x0] == [0, 1, 2]


def test_random_values_that_do_not_fit_are_refused_before_running(write_study: WriteStudy) -> None:
    from fmionnx.core.errors import DiagnosticError

    study = write_study(SAMPLED)  # a random stop time is not a whole number of 0.01 s steps
    with pytest.raises(DiagnosticError) as caught:
        plan_study(study)
    (problem,) = caught.value.diagnostics
    assert problem.code == "E103"
    assert "not a whole number of base steps" in problem.message


def test_resume_runs_only_the_unfinished_cases(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    study = write_study(SAMPLED.replace("{random: {low: 0.2, high: 0.9}}", "[0.5]"))
    plan = plan_study(study)[0]
    out = tmp_path / "out"
    full = run_sweep(plan, out, scheduler=cluster, keep_results=True).table
    records = out / "records"
    kept = {p.name: p.read_text() for p in records.iterdir()}
    # an interruption: two cases never finished, no table written yet
    for name in ("case-0001.json", "case-0004.json"):
        (records / name).unlink()
    (out / "cases.parquet").unlink()
    shutil.rmtree(out / "cases" / "case-0004")
    with pytest.raises(StudyFolderError, match="--resume"):
        run_sweep(plan, out, scheduler=cluster)
    resumed = run_sweep(plan, out, scheduler=cluster, resume=True, keep_results=True)
    assert resumed.resumed == 4
    for name, text in kept.items():  # finished cases were not run again
        if name not in ("case-0001.json", "case-0004.json"):
            assert (records / name).read_text() == text
    pd.testing.assert_frame_equal(_stable(resumed.table), _stable(full))
    csv = (out / "cases" / "case-0004" / "results.csv").read_text().splitlines()
    assert csv[0].split(",")[0] == "time"
    assert "gain.y" in csv[0]
    assert len(csv) == 1 + 51  # 0 .. 0.5 s in steps of 0.01
    # another study in the same folder is refused, even with --resume
    other = write_study(
        SAMPLED.replace("[1, 2]", "[1, 3]").replace("{random: {low: 0.2, high: 0.9}}", "[0.5]")
    )
    with pytest.raises(StudyFolderError, match="another study"):
        run_sweep(plan_study(other)[0], out, scheduler=cluster, resume=True)
    assert json.loads((out / "study.json").read_text())["fingerprint"] == plan.fingerprint
    # --force starts afresh: every case runs again, nothing of the first study is left
    (out / "notes.txt").write_text("mine")
    again = run_sweep(plan, out, scheduler=cluster, force=True)
    assert again.resumed == 0
    assert not (out / "cases").exists()  # kept results of the first run removed
    assert (out / "notes.txt").read_text() == "mine"  # what the study did not write stays
    pd.testing.assert_frame_equal(_stable(again.table), _stable(full))


def test_the_command_prints_a_summary_and_the_best_cases(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    study = write_study(
        "fmionnx: 1\nsystem: system.yaml\nisolate: [none]\nparameters:\n  gain.k: [1, 3, 2]\n"
        "metrics:\n  y_end: final(gain.y)\nobjective: {maximize: y_end}\n"
    )
    args = ["sweep", str(study), "--out", str(tmp_path / "out"), "--scheduler", cluster]
    result = CliRunner().invoke(app, args, env={"COLUMNS": "100", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    lines = [line.strip() for line in result.output.splitlines()]
    assert "│ cases       │ 3" in "\n".join(lines)
    assert any(line.startswith("│ check small │ 2 of 3 passed") for line in lines)
    ranked = [line.split("│")[1].strip() for line in lines if line.startswith("│ case-")]
    assert ranked == ["case-0001", "case-0002", "case-0000"]  # k = 3, 2, 1
    again = CliRunner().invoke(app, args, env={"COLUMNS": "100"})
    assert again.exit_code == 2
    assert "--resume finishes it, --force starts afresh" in " ".join(again.output.split())
