"""fmionnx deletes only files it can prove it wrote, and writes through no planted link.

What it may delete in a results folder used to follow a file anybody could write: a forged
``run.json`` listing ``thesis.txt`` made ``fmionnx run`` delete it, without ``--force``, and
``sweep --out DIR --force`` emptied any folder holding a file named ``study.json``. ``sweep
--resume`` wrote into ``records``/``cases`` links pointing elsewhere, and ``compile -o X``
wrote through a link planted at ``X.partial`` and replaced any file at ``X``. The ownership
record (``fmionnx.core.owned``) proves each file by its identity; links are never followed.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.cli import app
from fmionnx.core.owned import MARKER, OwnedFolder
from fmionnx.pipeline.sweep import plan_study
from fmionnx.results.study import StudyFolder, StudyFolderError

SYSTEM = """\
fmionnx: 1
name: gain
run: {{stop: 0.05, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}}}
{plots}"""
PLOT = "plots:\n  - {y: [gain.y], file: gain}\n"
STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2]
metrics:
  y_end: final(gain.y)
"""


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "200"})
    return result.exit_code, " ".join(result.output.split())


def _tree(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (links as their target's name) with its content."""
    found = {}
    for path in sorted(folder.rglob("*")):
        name = path.relative_to(folder).as_posix()
        if path.is_symlink():
            found[name] = f"-> {path.readlink()}"
        elif path.is_file():
            found[name] = path.read_text(errors="replace")
    return found


@pytest.fixture
def project(tmp_path: Path, fixture_fmu, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "system.yaml").write_text(SYSTEM.format(gain=fixture_fmu("Gain"), plots=PLOT))
    monkeypatch.chdir(tmp_path)
    return tmp_path


# -- run --out ---------------------------------------------------------------------------------


def test_a_forged_run_json_makes_run_delete_nothing(project: Path) -> None:
    out = project / "thesis"
    (out / "sub").mkdir(parents=True)
    (out / "thesis.txt").write_text("three years of work\n")
    (out / "sub" / "n.txt").write_text("notes\n")
    forged = {"versions": {"fmionnx": "0"}, "files": ["thesis.txt", "sub/n.txt"]}
    (out / "run.json").write_text(json.dumps(forged))
    code, output = _cli("run", "system.yaml", "--out", "thesis", "-q")
    assert code == 2  # a folder fmionnx cannot prove is its own is refused...
    assert "holds files that are not the output of an earlier fmionnx run" in output
    assert (out / "thesis.txt").read_text() == "three years of work\n"
    assert _cli("run", "system.yaml", "--out", "thesis", "-q", "--force")[0] == 0
    assert (out / "thesis.txt").read_text() == "three years of work\n"  # ...and with --force
    assert (out / "sub" / "n.txt").read_text() == "notes\n"  # it writes, deleting nothing


def test_a_rerun_deletes_no_file_that_changed_since_fmionnx_wrote_it(project: Path) -> None:
    assert _cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    (project / "out" / "gain.png").write_text("my own picture now\n")  # same name, not ours
    (project / "system.yaml").write_text(
        (project / "system.yaml").read_text().replace(PLOT, "")
    )  # the next run draws no plot: gain.png would be stale
    assert _cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    assert (project / "out" / "gain.png").read_text() == "my own picture now\n"


def test_a_forged_ownership_record_deletes_nothing_it_does_not_prove(project: Path) -> None:
    out = project / "out"
    assert _cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    (project / "thesis.txt").write_text("mine\n")
    (out / "notes.txt").write_text("mine too\n")
    info = (project / "thesis.txt").stat()
    forged = [
        {"name": "../thesis.txt", "device": info.st_dev, "inode": info.st_ino,
         "size": info.st_size, "mtime_ns": info.st_mtime_ns},
        {"name": str(project / "thesis.txt"), "device": info.st_dev, "inode": info.st_ino,
         "size": info.st_size, "mtime_ns": info.st_mtime_ns},
        {"name": "notes.txt", "device": 0, "inode": 1, "size": 9, "mtime_ns": 0},
    ]  # fmt: skip
    with (out / MARKER).open("a") as stream:
        stream.writelines(json.dumps(entry) + "\n" for entry in forged)
    assert _cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    assert (project / "thesis.txt").read_text() == "mine\n"
    assert (out / "notes.txt").read_text() == "mine too\n"


def test_a_proven_file_is_not_deleted_through_a_link(tmp_path: Path) -> None:
    """The record proves ``sub/n.txt``; ``sub`` then becomes a link to where the file went:
    the very file, reached through a link, is left."""
    out = tmp_path / "out"
    (out / "sub").mkdir(parents=True)
    (out / "sub" / "n.txt").write_text("written by fmionnx, then moved by the user\n")
    owned = OwnedFolder(out)
    owned.record([out / "sub" / "n.txt"])
    (out / "sub").rename(tmp_path / "kept")
    (out / "sub").symlink_to(tmp_path / "kept")
    assert owned.remove_all() == []
    assert (tmp_path / "kept" / "n.txt").exists()


# -- sweep --out ---------------------------------------------------------------------------


@pytest.fixture
def study(project: Path) -> Path:
    path = project / "study.yaml"
    path.write_text(STUDY)
    return path


def test_sweep_force_deletes_nothing_in_a_folder_that_merely_holds_a_study_json(
    project: Path, study: Path
) -> None:
    documents = project / "documents"
    (documents / "records").mkdir(parents=True)
    (documents / "cases" / "case-0000").mkdir(parents=True)
    (documents / "study.json").write_text('{"format": "fmionnx-study"}')
    (documents / "holiday.png").write_text("a photo\n")
    (documents / "cases.csv").write_text("my table\n")
    (documents / "records" / "case-0000.json").write_text('{"id": "case-0000"}')
    (documents / "cases" / "case-0000" / "results.csv").write_text("my results\n")
    before = _tree(documents)
    code, output = _cli("sweep", str(study), "--out", "documents", "--force", "--workers", "1")
    assert code == 2, output
    assert "holds a study.json that fmionnx cannot prove it wrote" in output
    assert _tree(documents) == before


def _outcome(case: str) -> CaseOutcome:
    import numpy as np

    signals = {"time": np.array([0.0, 0.01]), "gain.y": np.array([1.0, 2.0])}
    return CaseOutcome(case, "ok", metrics={"y_end": 2.0}, signals=signals)


def test_sweep_force_deletes_only_what_the_study_wrote(study: Path, project: Path) -> None:
    plan = plan_study(study)[0]
    out = project / "results"
    folder = StudyFolder(out, plan)
    folder.prepare(resume=False)
    for case in plan.cases:
        folder.record(_outcome(case.id))
    folder.write_table(folder.table())
    (out / "records" / "mine.json").write_text("{}")  # the user's, in the study's folders
    (out / "cases" / "notes.txt").write_text("mine\n")
    (out / "cases.csv").write_text("edited by hand\n")  # was the study's: changed since
    assert folder.prepare(resume=False, force=True) == set()
    assert _tree(out) == {
        ".fmionnx-owned": (out / MARKER).read_text(),
        "cases.csv": "edited by hand\n",
        "cases/notes.txt": "mine\n",
        "records/mine.json": "{}",
        "study.json": (out / "study.json").read_text(),  # written afresh
    }


@pytest.mark.parametrize("name", ["records", "cases"])
def test_sweep_resume_writes_nothing_through_a_planted_link(
    study: Path, project: Path, name: str
) -> None:
    plan = plan_study(study)[0]
    out = project / "results"
    folder = StudyFolder(out, plan)
    folder.prepare(resume=False)
    folder.record(_outcome(plan.cases[0].id))
    elsewhere = project / "elsewhere"
    elsewhere.mkdir()
    if (out / name).exists():
        (out / name).rename(project / "moved")
    (out / name).symlink_to(elsewhere)
    refused = f"`{out / name}` is a link or a file"
    with pytest.raises(StudyFolderError, match=refused):
        StudyFolder(out, plan).prepare(resume=True)
    with pytest.raises(StudyFolderError, match=refused):  # planted while the study runs
        folder.record(_outcome(plan.cases[1].id))
    assert list(elsewhere.iterdir()) == []


# -- compile -o ------------------------------------------------------------------------------


def test_compile_writes_nothing_through_a_link_planted_beside_its_output(project: Path) -> None:
    (project / "precious.txt").write_text("mine\n")
    (project / "gain.fmionnx.json.partial").symlink_to(project / "precious.txt")
    assert _cli("compile", "system.yaml", "-o", "gain.fmionnx.json", "-q")[0] == 0
    assert (project / "precious.txt").read_text() == "mine\n"
    assert json.loads((project / "gain.fmionnx.json").read_text())["format"]


def test_compile_replaces_only_a_compiled_system_without_force(project: Path) -> None:
    (project / "gain.fmionnx.json").write_text("my hand-written notes\n")
    code, output = _cli("compile", "system.yaml", "-o", "gain.fmionnx.json", "-q")
    assert code == 2
    assert "exists and is not a compiled system written by `fmionnx compile`" in output
    assert (project / "gain.fmionnx.json").read_text() == "my hand-written notes\n"
    assert _cli("compile", "system.yaml", "-o", "gain.fmionnx.json", "-q", "--force")[0] == 0
    assert _cli("compile", "system.yaml", "-o", "gain.fmionnx.json", "-q")[0] == 0  # its own
    (project / "other.txt").write_text("mine\n")
    (project / "gain.fmionnx.json").unlink()
    (project / "gain.fmionnx.json").symlink_to(project / "other.txt")
    assert _cli("compile", "system.yaml", "-o", "gain.fmionnx.json", "-q")[0] == 2
    assert (project / "other.txt").read_text() == "mine\n"
