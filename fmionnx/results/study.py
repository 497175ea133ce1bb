"""A study's results folder: one record per finished case, then the table of all cases.

Layout of ``DIR``::

    study.json            what was run: the plan's fingerprint, targets, metrics, checks, cases
    records/<case>.json   one per finished case, written atomically as it finishes
    cases/<case>/results.csv   with --keep-results
    cases/<case>/run.rrd       with --rrd: the case's Rerun recording
    cases.parquet, cases.csv   one row per case (written at the end, from the records)
    *.png                 summary plots

The records are the durable progress: an interrupted study loses at most the cases under way,
and ``--resume`` runs only the cases without a record. The table is built from the records
alone, in case order, so a study run twice (or resumed) gives the same table -- apart from the
``wall_time`` and ``worker`` columns.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import StudyPlan
from fmionnx.core.errors import FmionnxError
from fmionnx.core.safewrite import atomic_binary, atomic_text, write_bytes_atomic

if TYPE_CHECKING:
    import pandas as pd

    from fmionnx.backends.sweep.case import CaseOutcome

#: The ``format`` of ``study.json``.
FORMAT = "fmionnx-study"
#: Columns that differ between two runs of the same study.
VOLATILE = ("wall_time", "worker")
#: Prefix of a check's column (the check's name follows).
CHECK_PREFIX = "check: "


class StudyFolderError(FmionnxError):
    """A results folder that cannot take this study (another study's, or not a study's)."""


@dataclass(frozen=True)
class StudyFolder:
    """The results folder of one plan."""

    out: Path
    plan: StudyPlan

    @property
    def records(self) -> Path:
        """Where finished cases are recorded."""
        return self.out / "records"

    def prepare(self, *, resume: bool, force: bool = False) -> set[str]:
        """Create the folder (or check it, with ``resume``); returns the finished cases' ids.

        Refused as :meth:`problem` says; with ``force`` what an earlier study wrote is removed
        first (nothing else).
        """
        problem = self.problem(resume=resume, force=force)
        if problem is not None:
            raise StudyFolderError(problem)
        marker = self.out / "study.json"
        if marker.exists() and force and not resume:
            self._clear()
        self.records.mkdir(parents=True, exist_ok=True)
        if not marker.exists():
            with atomic_text(marker) as stream:
                json.dump(self.description(), stream, indent=2)
                stream.write("\n")
        return self.finished()

    def problem(self, *, resume: bool, force: bool = False) -> str | None:
        """Why the folder cannot take this study (None: it can), touching nothing.

        A folder holding another study's records is refused (resuming would mix two plans);
        without ``resume`` a folder that already holds a study is refused too, so finished
        results are never overwritten by accident -- unless ``force`` says to start afresh.
        """
        marker = self.out / "study.json"
        if marker.exists() and force and not resume:
            return None
        if marker.exists():
            if not resume:
                return (
                    f"`{self.out}` already holds a study's results: --resume finishes it, "
                    "--force starts afresh"
                )
            try:
                previous = json.loads(marker.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                previous = {}
            if previous.get("fingerprint") != self.plan.fingerprint:
                return (
                    f"`{self.out}` holds the results of another study (or of this one before it "
                    "changed): --resume continues only the same study"
                )
        elif self.out.exists() and any(self.out.iterdir()):
            return f"`{self.out}` is not empty and holds no study: choose a new or empty folder"
        return None

    def _clear(self) -> None:
        """Remove what a study writes in ``out`` (records, kept results, table, plots)."""
        import shutil

        for folder in (self.records, self.out / "cases"):
            shutil.rmtree(folder, ignore_errors=True)
        for pattern in ("cases.parquet", "cases.csv", "*.png", "study.json"):
            for path in self.out.glob(pattern):
                path.unlink()

    def description(self) -> dict[str, Any]:
        """``study.json``."""
        plan = self.plan
        return {
            "format": FORMAT,
            "version": 1,
            "fingerprint": plan.fingerprint,
            "system": plan.system.name,
            "system_hash": plan.system.content_hash,
            "targets": list(plan.targets),
            "metrics": {m.name: m.expression for m in plan.metrics},
            "checks": list(plan.check_names),
            "cases": {c.id: {s.target: _plain(s.value) for s in c.settings} for c in plan.cases},
        }

    def finished(self) -> set[str]:
        """Ids of the cases with a record of this plan."""
        ids = {c.id for c in self.plan.cases}
        done = set()
        for path in self.records.glob("*.json"):
            record = _read(path)
            if record is not None and record.get("id") in ids and path.stem == record["id"]:
                done.add(str(record["id"]))
        return done

    def record(self, outcome: CaseOutcome) -> None:
        """Write the case's record (and its results.csv when kept); atomic, so a record is
        either whole or absent."""
        if outcome.signals is not None:
            _write_results(self.out / "cases" / outcome.id / "results.csv", outcome.signals)
        if outcome.rrd is not None:  # sweep --rrd: the case's recording, made on its worker
            folder = self.out / "cases" / outcome.id
            folder.mkdir(parents=True, exist_ok=True)
            write_bytes_atomic(folder / "run.rrd", outcome.rrd)
        with atomic_text(self.records / f"{outcome.id}.json") as stream:
            json.dump(outcome.as_json(), stream, indent=1, sort_keys=True)
            stream.write("\n")

    def table(self) -> pd.DataFrame:
        """One row per case with a record, in case order."""
        import pandas as pd

        rows = []
        for case in self.plan.cases:
            record = _read(self.records / f"{case.id}.json")
            if record is None:
                continue
            row: dict[str, Any] = {"case": case.id}
            for setting in case.settings:
                row[setting.target] = _cell(setting.value)
            metrics = record.get("metrics", {})
            for metric in self.plan.metrics:
                value = metrics.get(metric.name)
                row[metric.name] = float(value) if isinstance(value, int | float) else math.nan
            checks = record.get("checks", {})
            for name in self.plan.check_names:
                row[CHECK_PREFIX + name] = bool(checks.get(name, False))
            row["status"] = record.get("status", "failed")
            row["message"] = _message(record)
            row["wall_time"] = float(record.get("wall_time", 0.0))
            row["worker"] = str(record.get("worker", ""))
            rows.append(row)
        columns = [
            "case",
            *self.plan.targets,
            *(m.name for m in self.plan.metrics),
            *(CHECK_PREFIX + n for n in self.plan.check_names),
            "status",
            "message",
            "wall_time",
            "worker",
        ]
        return pd.DataFrame(rows, columns=columns)

    def write_table(self, table: pd.DataFrame) -> list[Path]:
        """``cases.parquet`` and ``cases.csv``, each written atomically."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        parquet = self.out / "cases.parquet"
        csv = self.out / "cases.csv"
        arrow = pa.Table.from_pandas(table, preserve_index=False)
        with atomic_binary(parquet) as stream:
            pq.write_table(arrow, stream)
        with atomic_text(csv) as stream:
            table.to_csv(stream, index=False, lineterminator="\n")
        return [parquet, csv]


def ranked(table: pd.DataFrame, plan: StudyPlan) -> pd.DataFrame:
    """The cases that completed, best first by the objective (empty without one)."""
    objective = plan.objective
    if objective is None:
        return table.iloc[0:0]
    done = table[(table["status"] == "ok") & table[objective.metric].notna()]
    return done.sort_values(
        [objective.metric, "case"],
        ascending=[objective.sense == "minimize", True],
        kind="stable",
    )


def _plain(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value


def _cell(value: object) -> object:
    """A setting as a table cell: a list (an array parameter) as its JSON text."""
    return json.dumps(list(value)) if isinstance(value, tuple) else value


def _message(record: dict[str, Any]) -> str:
    message = str(record.get("message", ""))
    notes = record.get("notes", {})
    if not message and isinstance(notes, dict) and notes:
        message = "; ".join(f"{k}: {v}" for k, v in sorted(notes.items()))
    return message


def _read(path: Path) -> dict[str, Any] | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and "id" in data else None


def _write_results(path: Path, signals: dict[str, Any]) -> None:
    import numpy as np

    from fmionnx.results.csvfile import write_csv
    from fmionnx.runtime.result import RunResult, RunStatus

    path.parent.mkdir(parents=True, exist_ok=True)
    time = np.asarray(signals["time"], dtype=np.float64)
    rest = {k: np.asarray(v, dtype=np.float64) for k, v in signals.items() if k != "time"}
    step = float(time[1] - time[0]) if len(time) > 1 else 0.0
    start = float(time[0]) if len(time) else 0.0
    stop = float(time[-1]) if len(time) else 0.0
    result = RunResult(
        "case",
        "inprocess",
        RunStatus.COMPLETED,
        start,
        stop,
        step,
        max(len(time) - 1, 0),
        0.0,
        time,
        rest,
    )
    write_csv(result, path)
