"""``--force`` removes only the files the study wrote, unchanged; a file it would write again
that was edited or put there since (the table, a record) refuses the folder, before anything
is deleted: the new study would otherwise write over it."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.cli import app
from fmionnx.pipeline.sweep import plan_study, run_sweep
from fmionnx.results.study import StudyFolder, StudyFolderError
from tests.sweep.conftest import WriteStudy

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters: {gain.k: [1, 2]}
metrics: {end: final(gain.y)}
"""


def _finished(write_study: WriteStudy, tmp_path: Path) -> StudyFolder:
    """A study folder as a finished study leaves it."""
    plan, _ = plan_study(write_study(STUDY))
    folder = StudyFolder(tmp_path / "out", plan)
    folder.prepare(resume=False)
    for case in plan.cases:
        folder.record(CaseOutcome(case.id, "ok", metrics={"end": 1.0}))
    folder.write_table(folder.table())
    return folder


@pytest.mark.parametrize("edited", ["cases.csv", "cases.parquet", "records/case-0001.json"])
def test_force_refuses_a_folder_whose_files_were_edited(
    write_study: WriteStudy, tmp_path: Path, edited: str
) -> None:
    folder = _finished(write_study, tmp_path)
    with (folder.out / edited).open("a", encoding="utf-8") as stream:
        stream.write("MY EDIT\n")
    before = {p: p.read_bytes() for p in folder.out.rglob("*") if p.is_file()}
    problem = folder.kept_in_the_way()
    assert problem is not None
    assert f"`{folder.out / edited}` is not the file the study wrote there" in problem
    with pytest.raises(StudyFolderError, match="is not the file the study wrote there"):
        run_sweep(folder.plan, folder.out, force=True)  # refused before any cluster starts
    assert {p: p.read_bytes() for p in folder.out.rglob("*") if p.is_file()} == before


def test_force_refuses_a_table_put_there(write_study: WriteStudy, tmp_path: Path) -> None:
    """A table of the user's where the study writes one (another inode, never recorded)."""
    folder = _finished(write_study, tmp_path)
    table = folder.out / "cases.csv"
    text = table.read_text()
    table.unlink()
    table.write_text(text)
    assert folder.kept_in_the_way() is not None


def test_force_starts_afresh_when_nothing_was_edited(
    write_study: WriteStudy, tmp_path: Path
) -> None:
    folder = _finished(write_study, tmp_path)
    (folder.out / "notes.txt").write_text("mine\n")  # not the study's: stays, in nobody's way
    assert folder.kept_in_the_way() is None
    assert folder.prepare(resume=False, force=True) == set()
    assert sorted(p.name for p in folder.out.iterdir()) == [
        ".fmionnx-owned", "notes.txt", "records", "study.json",
    ]  # fmt: skip


def test_sweep_force_keeps_an_edited_table(write_study: WriteStudy, tmp_path: Path) -> None:
    """End to end: the reported case, `fmionnx sweep --force` after editing cases.csv."""
    study, out = write_study(STUDY), tmp_path / "out"
    command = ["sweep", str(study), "--out", str(out), "--workers", "1", "-q"]
    assert CliRunner().invoke(app, command).exit_code == 0
    table = out / "cases.csv"
    edited = table.read_text() + "MY EDIT\n"
    table.write_text(edited)
    result = CliRunner().invoke(app, [*command, "--force"], env={"COLUMNS": "200"})
    assert result.exit_code == 2, result.output
    assert "cases.csv` is not the file the study wrote there" in " ".join(result.output.split())
    assert table.read_text() == edited


def test_a_stop_while_a_record_is_written_lands_after_it_is_noted(
    write_study: WriteStudy, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The review of this change: a Ctrl-C between a record's write and its note in the
    ownership record left it unproven, and the `--force` that follows an interrupted study
    refused the folder as edited. The stop now waits for the note."""
    import json as json_module
    import signal

    from fmionnx.results import study as study_module
    from fmionnx.runtime.stopping import StopRequested, stop_on_signals

    plan, _ = plan_study(write_study(STUDY))
    folder = StudyFolder(tmp_path / "out", plan)
    folder.prepare(resume=False)
    first = plan.cases[0]

    dump = json_module.dump

    def dump_then_ctrl_c(*args: object, **kwargs: object) -> None:
        dump(*args, **kwargs)  # type: ignore[arg-type]
        signal.raise_signal(signal.SIGINT)  # as if it came right after the write

    monkeypatch.setattr(study_module.json, "dump", dump_then_ctrl_c)
    with stop_on_signals(), pytest.raises(StopRequested):
        folder.record(CaseOutcome(first.id, "ok", metrics={"end": 1.0}))
    assert f"records/{first.id}.json" in folder.owned.proven_names()
    assert folder.kept_in_the_way() is None  # `--force` may start afresh


@pytest.mark.parametrize("edited", ["cases.csv", "cases.parquet"])
def test_resume_refuses_an_edited_table_and_keeps_it(
    write_study: WriteStudy, tmp_path: Path, edited: str
) -> None:
    """`--resume` wrote the table again over an edited one (a bug hunt)."""
    folder = _finished(write_study, tmp_path)
    (folder.out / "records" / "case-0001.json").unlink()  # a case left to resume
    with (folder.out / edited).open("a", encoding="utf-8") as stream:
        stream.write("MY EDIT\n")
    before = {p: p.read_bytes() for p in folder.out.rglob("*") if p.is_file()}
    problem = folder.kept_in_the_way(resume=True)
    assert problem is not None
    assert f"`{folder.out / edited}` is not the file the study wrote there" in problem
    assert "--resume writes the table again; move it out of the folder first" in problem
    with pytest.raises(StudyFolderError, match="--resume writes the table again"):
        run_sweep(folder.plan, folder.out, resume=True)
    assert {p: p.read_bytes() for p in folder.out.rglob("*") if p.is_file()} == before


def test_resume_is_not_refused_by_plots_or_records_it_does_not_write(
    write_study: WriteStudy, tmp_path: Path
) -> None:
    folder = _finished(write_study, tmp_path)
    (folder.out / "passfail.png").write_bytes(b"drawn, then interrupted before its note")
    assert folder.kept_in_the_way(resume=True) is None
    assert folder.kept_in_the_way() is not None  # `--force` would write over it
