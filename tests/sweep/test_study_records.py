"""A study whose targets are not all numbers, and the records ``--resume`` reads back.

* a text or an array target has no axis: the plots name it in a note, and a metric's points
  are joined by a line only when the study has one target (they zigzagged through cases that
  differed in the text target);
* a record that does not check out (an unknown status, a field of the wrong type, metrics or
  checks that are not the study's) is damaged: its case runs again (it gave a made-up row);
* a folder where a record goes is refused with the folder's other problems, before any case
  runs (exit 2; it was found after the case had run, exit 1).

One shared local cluster (2 workers)."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.cli import app
from fmionnx.pipeline.sweep import plan_study, run_sweep
from fmionnx.results import study_plots
from fmionnx.results.study import StudyFolder

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

SYSTEM = """\
fmionnx: 1
name: mixed
run: {stop: 0.1, step: 0.01}
components:
  g: {kind: fmu, path: models/Gain.fmu}
  s: {kind: fmu, path: models/Strings2.fmu}
  c: {kind: fmu, path: models/Count2.fmu}
checks:
  - name: fin
    expect: final(s.labelLength) > 0
"""

#: Eight cases: a text, an array and an integer target; ``len`` is the label's length.
STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  s.label: ['a', 'bb']
  g.v: [[0, 0, 1], [1, 0, 0]]
  c.n: [-2, 2]
metrics:
  len: final(s.labelLength)
"""


@pytest.fixture
def mixed(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    """The study file, beside its system and copies of the three FMUs."""
    models = tmp_path / "models"
    models.mkdir()
    for name in ("Gain", "Strings2", "Count2"):
        shutil.copy(fixture_fmu(name), models / f"{name}.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    study = tmp_path / "study.yaml"
    study.write_text(STUDY, encoding="utf-8")
    return study


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures the plots would save (drawn by matplotlib for real; no file written)."""
    figures: list[Any] = []

    def keep(figure: Any, path: Path) -> Path:
        figures.append(figure)
        return path

    monkeypatch.setattr(study_plots, "save_figure", keep)
    return figures


def test_targets_that_are_not_numbers_are_named_and_join_no_line(
    mixed: Path, tmp_path: Path, cluster: str, drawn: list[Any]
) -> None:
    plan = plan_study(mixed)[0]
    out = tmp_path / "out"
    result = run_sweep(plan, out, scheduler=cluster)
    assert result.cases.column("len") == [1.0] * 4 + [2.0] * 4
    assert sorted(p.name for p in out.glob("*.png")) == ["metric-len.png", "passfail.png"]
    for draw in study_plots.study_drawings(result.cases, plan, out):
        draw()
    metric, passfail = drawn
    (panel,) = metric.axes  # c.n alone: the only number
    assert panel.get_xlabel() == "c.n"
    (points,) = panel.lines
    assert points.get_linestyle() == "None"  # the cases at c.n = -2 differ in s.label
    assert points.get_marker() == "o"
    for figure in (metric, passfail):
        note = figure.get_supxlabel()
        assert "s.label (text)" in note
        assert "g.v (an array)" in note


def test_a_study_of_one_target_still_joins_its_points(
    mixed: Path, tmp_path: Path, drawn: list[Any]
) -> None:
    mixed.write_text(
        STUDY.replace("  s.label: ['a', 'bb']\n  g.v: [[0, 0, 1], [1, 0, 0]]\n", ""), "utf-8"
    )
    plan = plan_study(mixed)[0]
    assert plan.targets == ("c.n",)
    folder = StudyFolder(tmp_path / "out", plan)
    folder.prepare(resume=False)
    for case in plan.cases:  # recorded as the driver records them
        folder.record(CaseOutcome(case.id, "ok", metrics={"len": 3.0}, checks={"fin": True}))
    for draw in study_plots.study_drawings(folder.table(), plan, folder.out):
        draw()
    (points,) = drawn[0].axes[0].lines
    assert points.get_linestyle() == "-"
    assert drawn[0].get_supxlabel() == ""  # nothing left out, nothing said


#: How each case's record is damaged (``None``: the key removed).
DAMAGE: dict[str, dict[str, Any]] = {
    "case-0001": {"metrics": {"len": "abc"}},
    "case-0002": {"status": "bogus"},
    "case-0003": {"checks": {"fin": "yes"}},
    "case-0004": {"wall_time": "x"},
    "case-0005": {"metrics": {"len": 1.0, "fy": 2.0}},  # a metric of another study
    "case-0006": {"metrics": {"len": None}, "notes": {}},  # no value, and no reason
}


def test_a_damaged_record_is_run_again_on_resume(mixed: Path, tmp_path: Path, cluster: str) -> None:
    plan = plan_study(mixed)[0]
    out = tmp_path / "out"
    first = run_sweep(plan, out, scheduler=cluster)
    records = out / "records"
    before = {p.stem: json.loads(p.read_text("utf-8")) for p in records.glob("*.json")}
    for case, fields in DAMAGE.items():
        record = {**before[case], **fields}
        (records / f"{case}.json").write_text(json.dumps(record), "utf-8")
    older = dict(before["case-0007"])
    del older["started"]  # as a record of an earlier version: still a record
    (records / "case-0007.json").write_text(json.dumps(older), "utf-8")
    assert StudyFolder(out, plan).finished() == {"case-0000", "case-0007"}

    resumed = run_sweep(plan, out, scheduler=cluster, resume=True)
    assert resumed.resumed == 2
    assert resumed.damaged == len(DAMAGE)  # said in the CLI's overview (`run again`)
    after = {p.stem: json.loads(p.read_text("utf-8")) for p in records.glob("*.json")}
    for case in DAMAGE:  # run again: a record written afresh
        assert after[case]["started"] != before[case]["started"], case
        assert after[case]["status"] == "ok"
    assert after["case-0000"] == before["case-0000"]
    table = resumed.cases
    assert table.column("status") == ["ok"] * 8
    assert table.column("len") == first.cases.column("len")
    assert table.column("check: fin") == [True] * 8
    assert table.column("message") == [""] * 8


def test_the_records_the_driver_writes_check_out(mixed: Path, tmp_path: Path) -> None:
    """Not stricter than the driver: a case that could not run measured nothing, a fault
    measured every metric, a metric without a value says why; each counts as finished."""
    plan = plan_study(mixed)[0]
    folder = StudyFolder(tmp_path / "out", plan)
    folder.prepare(resume=False)
    first, second, third = (c.id for c in plan.cases[:3])
    folder.record(CaseOutcome(first, "failed", "a setting that does not fit"))
    folder.record(CaseOutcome(second, "fault", "FMI error", metrics={"len": float("nan")}))
    folder.record(
        CaseOutcome(third, "ok", metrics={"len": None}, checks={"fin": False}, notes={"len": "n"})
    )
    assert folder.finished() == {first, second, third}
    table = folder.table()
    assert table.column("status") == ["failed", "fault", "ok"]
    assert table.column("message")[2] == "len: n"


@pytest.mark.parametrize(
    ("planted", "options"),
    [
        ("records/case-0001.json", ["--resume"]),
        ("records/case-0001.json", ["--force"]),
        ("cases/case-0002/results.csv", ["--resume", "--keep-results"]),
    ],
)
def test_a_folder_where_a_record_goes_is_refused_before_any_case_runs(
    mixed: Path, tmp_path: Path, cluster: str, planted: str, options: list[str]
) -> None:
    plan = plan_study(mixed)[0]
    out = tmp_path / "out"
    StudyFolder(out, plan).prepare(resume=False)  # a study begun, none of its cases finished
    (out / planted).mkdir(parents=True)
    command = ["sweep", str(mixed), "--out", str(out), "--scheduler", cluster, "-q", *options]
    result = CliRunner().invoke(app, command)
    assert result.exit_code == 2, result.output
    message = " ".join(result.output.split())
    assert f"error: `{out / planted}` is a folder where the study writes a file" in message
    assert list((out / "records").glob("*.json")) == (
        [out / planted] if "records" in planted else []
    )
    assert (out / planted).is_dir()
