"""A study folder tampered with between a run and its ``--resume`` is read safely.

A record or ``study.json`` that is a FIFO hung ``sweep --resume`` (a read that never starts,
Ctrl-C ignored), a link to ``/dev/zero`` took 3.9 GB, ``wall_time: "soon"`` and a
``study.json`` of ``[]`` raised. Records are read only as regular files of bounded size
(``fmionnx.core.regularfile``), their fields taken only when of the right type; a record that
cannot be read is no record (its case runs again), and a ``study.json`` that is not the
study's own file is refused with where.
"""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.pipeline.sweep import plan_study
from fmionnx.results.study import StudyFolder, StudyFolderError

SYSTEM = """\
fmionnx: 1
name: gain
run: {{stop: 0.05, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}}}
"""
STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2, 3]
metrics:
  y_end: final(gain.y)
"""


@pytest.fixture
def folder(tmp_path: Path, fixture_fmu) -> StudyFolder:
    (tmp_path / "system.yaml").write_text(SYSTEM.format(gain=fixture_fmu("Gain")), "utf-8")
    (tmp_path / "study.yaml").write_text(STUDY, "utf-8")
    plan = plan_study(tmp_path / "study.yaml")[0]
    study = StudyFolder(tmp_path / "results", plan)
    study.prepare(resume=False)
    for case in plan.cases:
        study.record(
            CaseOutcome(id=case.id, status="ok", metrics={"y_end": 1.0}, wall_time=0.5, worker="w")
        )
    return study


def _within(seconds: float, call: Callable[[], object]) -> object:
    """``call()`` on a thread: fails the test when it has not returned in ``seconds``."""
    box: list[object] = []
    failed: list[BaseException] = []

    def target() -> None:
        try:
            box.append(call())
        except BaseException as exc:  # raised again on the test thread
            failed.append(exc)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"still reading after {seconds} s"
    if failed:
        raise failed[0]
    return box[0]


def _fifo(path: Path) -> None:
    path.unlink()
    os.mkfifo(path)


def _to_dev_zero(path: Path) -> None:
    path.unlink()
    path.symlink_to("/dev/zero")


@pytest.mark.parametrize("tamper", [_fifo, _to_dev_zero], ids=["fifo", "dev-zero"])
def test_a_record_that_is_no_regular_file_is_no_record(
    folder: StudyFolder, tamper: Callable[[Path], None]
) -> None:
    tamper(folder.records / "case-0001.json")
    finished = _within(30, lambda: folder.prepare(resume=True))
    assert finished == {"case-0000", "case-0002"}  # case-0001 runs again
    table = _within(30, folder.table)
    assert table.column("case") == ["case-0000", "case-0002"]  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    "record",
    [
        {"id": "case-0001", "status": "ok", "wall_time": "soon", "metrics": {"y_end": 1.0}},
        {"id": "case-0001", "status": "ok", "metrics": ["y_end"], "checks": "all"},
        {"id": "case-0001", "status": {"ok": True}, "notes": [1, 2], "wall_time": True},
        {"id": ["case-0001"], "status": "ok"},
        {"id": "case-0001", "status": "ok", "wall_time": 10**400, "metrics": {"y_end": -(10**400)}},
        {
            "id": "case-0001",
            "status": "ok",
            "message": "\ud800",
            "worker": "w\udfff",
            "metrics": {"y_end": 1.0},
        },
    ],
    ids=[
        "wall-time-text",
        "metrics-list",
        "status-mapping",
        "id-list",
        "huge-numbers",
        "surrogates",
    ],
)
def test_a_record_with_fields_of_the_wrong_type_gives_a_table(
    folder: StudyFolder, record: dict[str, object]
) -> None:
    (folder.records / "case-0001.json").write_text(json.dumps(record), "utf-8")
    finished = folder.prepare(resume=True)
    table = folder.table()
    rows = table.to_pandas().set_index("case")
    if record.get("message") != "\ud800":
        # a damaged record, no record at all: the case runs again, and has no row (a row
        # of made-up values was never run again: docs/sweep.md, Resuming)
        assert "case-0001" not in finished
        assert "case-0001" not in rows.index
    else:
        assert rows.loc["case-0001"]["status"] == "ok"
    folder.write_table(table)  # parquet takes it: every column of one type
    assert (folder.out / "cases.csv").read_text("utf-8")  # and so does UTF-8


@pytest.mark.parametrize(
    "tamper",
    [
        lambda p: p.write_text("[]", "utf-8"),
        lambda p: p.write_text('{"fingerprint": [1]}', "utf-8"),
        _fifo,
        _to_dev_zero,
    ],
    ids=["list", "wrong-fingerprint", "fifo", "dev-zero"],
)
def test_a_study_json_that_is_not_the_studys_is_refused_with_where(
    folder: StudyFolder, tamper: Callable[[Path], None]
) -> None:
    marker = folder.out / "study.json"
    tamper(marker)
    with pytest.raises(StudyFolderError, match=r"study\.json|another study") as refused:
        _within(30, lambda: folder.prepare(resume=True))
    assert str(folder.out) in str(refused.value)
