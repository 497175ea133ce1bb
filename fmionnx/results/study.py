"""A study's results folder: one record per finished case, then the table of all cases.

Layout of ``DIR``::

    study.json            what was run: the plan's fingerprint, targets, metrics, checks, cases
    records/<case>.json   one per finished case, written atomically as it finishes
    cases/<case>/results.csv   with --keep-results
    cases/<case>/run.rrd       with --rrd: the case's Rerun recording
    cases.parquet, cases.csv   one row per case (written at the end, from the records)
    *.png                 summary plots

The records are the durable progress: an interrupted study loses at most the cases under way,
and ``--resume`` runs only the cases without a record (a damaged one, not as a study writes
it, is none: :func:`record_problem`). The table is built from the records
alone, in case order, so a study run twice (or resumed) gives the same table -- apart from the
``wall_time`` and ``worker`` columns.

Every file written is noted in the folder's ownership record (:mod:`fmionnx.core.owned`):
``--force`` deletes only files that record proves fmionnx wrote, and only in a folder whose
``study.json`` it proves (a folder that merely holds a file of that name is not a study's).
``records`` and ``cases`` are folders of the study's own, never links to elsewhere.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import CHECK_PREFIX, TABLE_COLUMNS, SettingValue, StudyPlan, owner
from fmionnx.core.errors import FmionnxError, ModelError
from fmionnx.core.owned import OwnedFolder, safe_folder
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import STUDY_FILE_BYTES
from fmionnx.core.safewrite import atomic_binary, atomic_text, write_bytes_atomic
from fmionnx.core.types import Scalar
from fmionnx.results.casetable import CaseTable
from fmionnx.runtime.stopping import shield_begin, shield_end

if TYPE_CHECKING:
    from fmionnx.backends.sweep.case import CaseOutcome

#: The ``format`` of ``study.json``.
FORMAT = "fmionnx-study"
#: A case's statuses (``fmionnx.backends.sweep.case.CaseStatus``); a record saying anything
#: else is damaged (:func:`record_problem`): its case runs again.
STATUSES = ("ok", "fault", "timeout", "failed")
#: Columns that differ between two runs of the same study.
VOLATILE = ("wall_time", "worker")
#: The study's description, and the folders it writes into.
DESCRIPTION, RECORDS, CASES = "study.json", "records", "cases"
#: How a record writes an infinite metric (:meth:`CaseOutcome.as_json`).
INFINITIES = ("inf", "-inf")
#: What a case's folder holds: its results (``--keep-results``) and recording (``--rrd``).
KEPT = ("results.csv", "run.rrd")
#: The study's table, written again whenever the study runs (resumed too).
TABLES = ("cases.csv", "cases.parquet")


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
        first (only what the ownership record proves it wrote; nothing else).
        """
        problem = self.problem(resume=resume, force=force)
        if problem is not None:
            raise StudyFolderError(problem)
        marker = self.out / DESCRIPTION
        afresh = force and not resume
        if afresh:
            self.owned.remove_all()
        self.out.mkdir(parents=True, exist_ok=True)
        self._folder(RECORDS, RECORDS)
        if not marker.exists():
            with atomic_text(marker) as stream:
                json.dump(self.description(), stream, indent=2)
                stream.write("\n")
            self.owned.note([marker])
        return set() if afresh else self.finished()

    @property
    def owned(self) -> OwnedFolder:
        """The folder's ownership record."""
        return OwnedFolder(self.out)

    def problem(self, *, resume: bool, force: bool = False) -> str | None:
        """Why the folder cannot take this study (None: it can), touching nothing.

        A folder holding another study's records is refused (resuming would mix two plans);
        without ``resume`` a folder that already holds a study is refused too, so finished
        results are never overwritten by accident -- unless ``force`` says to start afresh,
        which needs a study fmionnx can prove it wrote (``study.json`` in its ownership
        record). ``records`` and ``cases`` must be folders, not links.
        """
        for name in (RECORDS, CASES):
            inside = self.out / name
            if inside.is_symlink() or (inside.exists() and not inside.is_dir()):
                return self._not_a_folder(name)
        marker = self.out / DESCRIPTION
        if marker.exists() or marker.is_symlink():
            if force and not resume:
                if not self.owned.proven(DESCRIPTION):
                    return (
                        f"`{self.out}` holds a {DESCRIPTION} that fmionnx cannot prove it "
                        "wrote (its ownership record does not list that very file), so "
                        "--force deletes nothing there: choose a new or empty folder"
                    )
                return self._folder_in_the_way()
            if not resume:
                return (
                    f"`{self.out}` already holds a study's results: --resume finishes it, "
                    "--force starts afresh"
                )
            if marker.is_symlink() or not marker.is_file():
                return (
                    f"`{marker}` is a link or a special file, not the description a study "
                    "writes: remove it or choose a new folder"
                )
            previous = _read_description(marker)
            if previous.get("fingerprint") != self.plan.fingerprint:
                return (
                    f"`{self.out}` holds the results of another study (or of this one before it "
                    "changed): --resume continues only the same study"
                )
        elif self.out.exists() and any(self.out.iterdir()):
            return f"`{self.out}` is not empty and holds no study: choose a new or empty folder"
        return self._folder_in_the_way()

    def _folder_in_the_way(self) -> str | None:
        """Why the study cannot write a file it writes (None: it can), touching nothing: a
        folder where a case's record (or kept results) goes, which no atomic write replaces.
        Found after the case had run, it stopped the study with exit 1 (a bug hunt); it is
        refused with the folder's other problems, before a cluster starts. A link there is
        no problem: the write replaces the link, never writes through it."""
        ids = {c.id for c in self.plan.cases}
        found = [
            f"{RECORDS}/{name}"
            for name in _folders(self.out / RECORDS)
            if name.endswith(".json") and name.removesuffix(".json") in ids
        ]
        for case in sorted(ids.intersection(_listing(self.out / CASES))):
            folder = f"{CASES}/{case}"
            found.extend(f"{folder}/{n}" for n in _folders(self.out / folder) if n in KEPT)
        if not found:
            return None
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        return (
            f"`{self.out / min(found)}`{more} is a folder where the study writes a file: "
            "remove it or choose a new folder"
        )

    def kept_in_the_way(self, *, resume: bool = False) -> str | None:
        """Why a study run with ``--force`` cannot start afresh here (None: it can), touching
        nothing: a file the study writes again (its table, a plot, a case's record or
        results) that the ownership record does not prove is the very file written -- edited,
        replaced or put there since. :meth:`prepare` keeps such a file, as it keeps anything
        it cannot prove it wrote (:mod:`fmionnx.core.owned`), but the new study would then
        write over it: the study refuses the folder before anything is deleted, as it does an
        edited ``study.json``.

        ``resume``: the files a resumed study writes again that a user may have edited, its
        table (``--resume`` wrote an edited ``cases.csv`` over). Not its plots: the plot
        worker's can be left unnoted by the very Ctrl-C a study is resumed after; they are
        drawn, not written by hand."""
        proven = self.owned.proven_names()
        names = self._rewritten() if not resume else self._tables()
        kept = sorted(n for n in names if n not in proven)
        if not kept:
            return None
        more = f" (and {len(kept) - 1} more)" if len(kept) > 1 else ""
        option = (
            "--resume writes the table again"
            if resume
            else (
                "--force deletes only the study's own files, unchanged, and the new study would "
                "write over it"
            )
        )
        return (
            f"`{self.out / kept[0]}`{more} is not the file the study wrote there (edited or "
            f"replaced since): {option}; move it out of the folder first"
        )

    def _tables(self) -> list[str]:
        return [n for n in TABLES if os.path.lexists(self.out / n)]

    def _rewritten(self) -> list[str]:
        """The files of the folder (names inside it) that this study writes when it starts
        afresh and that exist now, found without following a link."""
        metrics = [m.name for m in self.plan.plotted_metrics]
        tops = [
            *TABLES, "passfail.png",
            *(f"{prefix}-{name}.png" for prefix in ("heatmap", "metric") for name in metrics),
        ]  # fmt: skip
        found = [name for name in tops if os.path.lexists(self.out / name)]
        ids = {c.id for c in self.plan.cases}
        found.extend(
            f"{RECORDS}/{name}"
            for name in _listing(self.out / RECORDS)
            if name.endswith(".json") and name.removesuffix(".json") in ids
        )
        for case in _listing(self.out / CASES):
            if case in ids:
                folder = f"{CASES}/{case}"
                found.extend(f"{folder}/{n}" for n in _listing(self.out / folder) if n in KEPT)
        return found

    def _folder(self, shown: str, name: str) -> Path:
        """``out/name``, made or found without following a link (StudyFolderError)."""
        try:
            return safe_folder(self.out, name)
        except OSError:
            raise StudyFolderError(self._not_a_folder(shown)) from None

    def _not_a_folder(self, name: str) -> str:
        return (
            f"`{self.out / name}` is a link or a file: a study writes its {name} only into a "
            "folder of its own; remove it or choose a new folder"
        )

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
        """Ids of the cases with a record of this plan that checks out (:meth:`read_record`);
        any other case runs (again)."""
        return {c.id for c in self.plan.cases if self.read_record(c.id) is not None}

    def read_record(self, case: str) -> dict[str, Any] | None:
        """Case ``case``'s record, or None where there is none this plan's study could have
        written: missing, cut short, another case's, or not of the shape
        :meth:`CaseOutcome.as_json` writes (:func:`record_problem`). Such a record is
        damaged, and its case runs again on ``--resume``: a record edited to
        ``"metrics": {"fy": "abc"}`` gave a row with ``fy`` empty and no reason, a
        ``"status": "bogus"`` a made-up ``failed`` row that was never run again."""
        record = _read(self.records / f"{case}.json")
        if record is None or record["id"] != case or record_problem(record, self.plan):
            return None
        return record

    def record(self, outcome: CaseOutcome) -> None:
        """Write the case's record (and its results.csv when kept); atomic, so a record is
        either whole or absent. Never through a link planted in the folder meanwhile: the
        folders are checked on the way (StudyFolderError)."""
        written: list[Path] = []
        with _noted_whole(self.owned, written):
            if outcome.signals is not None:
                folder = self._folder(CASES, f"{CASES}/{outcome.id}")
                written.append(_write_results(folder / "results.csv", outcome.signals))
            if outcome.rrd is not None:  # sweep --rrd: the case's recording, made on its worker
                folder = self._folder(CASES, f"{CASES}/{outcome.id}")
                written.append(write_bytes_atomic(folder / "run.rrd", outcome.rrd))
            path = self._folder(RECORDS, RECORDS) / f"{outcome.id}.json"
            with atomic_text(path) as stream:
                json.dump(outcome.as_json(), stream, indent=1, sort_keys=True)
                stream.write("\n")
            written.append(path)

    def table(self) -> CaseTable:
        """One row per case with a record, in case order (:mod:`.casetable`: no pandas)."""
        first, *last = TABLE_COLUMNS  # `case`, then the values, then the outcome
        columns = (
            first,
            *self.plan.targets,
            *(m.name for m in self.plan.metrics),
            *(CHECK_PREFIX + n for n in self.plan.check_names),
            *last,
        )
        rows = []
        real = _real_targets(self.plan)
        for case in self.plan.cases:
            record = self.read_record(case.id)  # checked: every field has its type
            if record is None:
                continue
            row: dict[str, Any] = {"case": case.id}
            for setting in case.settings:
                value = _real(setting.value) if setting.target in real else setting.value
                row[setting.target] = _cell(value)
            metrics = record.get("metrics", {})
            for metric in self.plan.metrics:
                row[metric.name] = _number(metrics.get(metric.name))
            checks = record.get("checks", {})
            for name in self.plan.check_names:
                row[CHECK_PREFIX + name] = checks.get(name) is True
            row["status"] = record["status"]
            empty = [m.name for m in self.plan.metrics if math.isnan(row[m.name])]
            row["message"] = _clean(_message(record, empty))
            row["wall_time"] = _number(record.get("wall_time", 0.0))
            row["worker"] = _clean(record.get("worker", ""))
            rows.append(tuple(row.get(name, math.nan) for name in columns))
        return CaseTable(columns, tuple(rows))

    def write_table(self, table: CaseTable) -> list[Path]:
        """``cases.parquet`` and ``cases.csv``, each written atomically."""
        import pyarrow.parquet as pq

        parquet = self.out / "cases.parquet"
        csv = self.out / "cases.csv"
        arrow = table.to_arrow()
        written: list[Path] = []
        with _noted_whole(self.owned, written):
            with atomic_binary(parquet) as stream:
                pq.write_table(arrow, stream)
            written.append(parquet)
            with atomic_text(csv) as stream:
                table.write_csv(stream)
            written.append(csv)
        return [parquet, csv]


def _listing(folder: Path) -> list[str]:
    """The names in ``folder``; none when it is missing, a link or not a folder (its own
    check refuses a link at ``records`` or ``cases``)."""
    if folder.is_symlink() or not folder.is_dir():
        return []
    try:
        return [entry.name for entry in os.scandir(folder)]
    except OSError:
        return []


def _folders(folder: Path) -> list[str]:
    """The names of the folders in ``folder`` (not links to one); none when it is missing,
    a link or not a folder."""
    if folder.is_symlink() or not folder.is_dir():
        return []
    try:
        with os.scandir(folder) as entries:
            return [e.name for e in entries if e.is_dir(follow_symlinks=False)]
    except OSError:
        return []


def ranked(table: CaseTable, plan: StudyPlan) -> list[dict[str, Any]]:
    """The cases that completed, best first by the objective (none without one); cases of
    the same value in case order."""
    objective = plan.objective
    if objective is None:
        return []
    metric = objective.metric
    done = [
        row
        for row in table.records()
        if row["status"] == "ok" and not _missing_number(row.get(metric))
    ]
    done.sort(key=lambda row: str(row["case"]))
    done.sort(key=lambda row: float(row[metric]), reverse=objective.sense != "minimize")
    return done


def _missing_number(value: object) -> bool:
    return not isinstance(value, int | float) or (isinstance(value, float) and math.isnan(value))


def _real_targets(plan: StudyPlan) -> set[str]:
    """The targets that take real numbers: the run settings (seconds), and parameters, inputs
    and system inputs whose ports are floats. Their columns are floats whatever the study file
    wrote (``gain.k: [1, 2]`` sets 1.0 and 2.0), so a column's type is the variable's."""
    system = plan.system
    kinds = {s.target: s.kind for s in plan.cases[0].settings} if plan.cases else {}
    inputs = {i.name: i for i in system.inputs}
    real = set()
    for target, kind in kinds.items():
        if kind in ("stop", "output_interval"):
            real.add(target)
        elif kind == "parameter" and target in inputs:
            reached = [
                system.component(t.ref.component).port(t.ref.port) for t in inputs[target].targets
            ]
            if reached and all(p.dtype.is_float for p in reached):
                real.add(target)
        elif kind == "parameter" and (found := owner(system, target)) is not None:
            port = system.component(found[0]).interface.port(found[1])
            if port is not None and port.dtype.is_float:
                real.add(target)
    return real


def _real(value: SettingValue) -> SettingValue:
    """``value`` with its integers as floats (an array's elements too)."""
    if isinstance(value, tuple):
        return tuple(_real_scalar(v) for v in value)
    return _real_scalar(value)


def _real_scalar(value: Scalar) -> Scalar:
    return float(value) if isinstance(value, int) and not isinstance(value, bool) else value


def _plain(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value


def _cell(value: object) -> object:
    """A setting as a table cell: a list (an array parameter) as its JSON text."""
    if isinstance(value, str):
        return _clean(value)
    return json.dumps(list(value)) if isinstance(value, tuple) else value


def _clean(text: str) -> str:
    """``text`` as UTF-8 can hold it: a record may carry a lone surrogate (``"\\ud800"`` in
    its JSON), which no file of the table could be written with; it is kept as ``\\ud800``."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def _message(record: dict[str, Any], empty: list[str]) -> str:
    """The ``message`` cell: the case's own message, else its notes (a metric without a value,
    a check that failed). A case with a message of its own (a fault) still says why each of
    its ``empty`` metrics has no value, as docs/sweep.md promises for every empty metric."""
    message = str(record.get("message", ""))
    notes = _mapping(record.get("notes"))
    if message:
        notes = {k: v for k, v in notes.items() if k in empty}
        return "; ".join([message, *(f"{k}: {v}" for k, v in sorted(notes.items()))])
    return "; ".join(f"{k}: {v}" for k, v in sorted(notes.items()))


def _load(path: Path) -> object:
    """The JSON in ``path``, or None where there is none to read.

    A study folder may have been tampered with between a run and its ``--resume``: a record
    or ``study.json`` that is a FIFO (a read that never starts), a link to ``/dev/zero`` (one
    that never ends), a file of gigabytes. Only a regular file within
    :data:`~fmionnx.core.resources.STUDY_FILE_BYTES` is read (:mod:`fmionnx.core.regularfile`).
    """
    try:
        text = read_regular(path, STUDY_FILE_BYTES, f"`{path.name}`")
        return json.loads(text.decode("utf-8"))
    except (OSError, ValueError, ModelError, RecursionError):
        return None


def _read(path: Path) -> dict[str, Any] | None:
    """A case's record, or None where ``path`` holds none (then the case runs again)."""
    data = _load(path)
    if isinstance(data, dict) and isinstance(data.get("id"), str):
        return data
    return None


def record_problem(record: dict[str, Any], plan: StudyPlan) -> str | None:
    """Why ``record`` is not one ``plan``'s study writes (None: it is one).

    What :meth:`CaseOutcome.as_json` writes: a known ``status``; text for ``message`` and
    ``worker``; a finite number for ``wall_time`` and ``started``; the study's metrics, each
    a finite number, ``"inf"``, ``"-inf"`` or null with a note saying why (all of them, but
    for a case that could not run, which measured none); the system's checks, each true or
    false; notes in text, on the study's metrics and checks. A field may be missing (a
    record of an earlier version has no ``started``): the table takes its default."""
    status = record.get("status")
    if status not in STATUSES:
        return f"an unknown status `{status}`"
    wrong = [name for name, fits in _FIELDS.items() if name in record and not fits(record[name])]
    if wrong:
        return f"`{wrong[0]}` is not {_FIELD_TYPES[wrong[0]]}"
    metrics, checks = record.get("metrics", {}), record.get("checks", {})
    notes = record.get("notes", {})
    names = {m.name for m in plan.metrics}
    unknown = sorted(set(metrics) - names) or sorted(set(checks) - set(plan.check_names))
    unknown = unknown or sorted(set(notes) - names - set(plan.check_names))
    if unknown:
        return f"`{unknown[0]}` is none of the study's metrics and checks"
    if status != "failed" and set(metrics) != names:
        return f"the metric `{sorted(names - set(metrics))[0]}` is missing"
    unexplained = sorted(n for n, v in metrics.items() if v is None and n not in notes)
    if unexplained:
        return f"the metric `{unexplained[0]}` has no value and no note saying why"
    return None


def _finite(value: object) -> bool:
    """A JSON number a float holds, finite (never a boolean, which JSON keeps apart)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer of hundreds of digits (JSON allows it)
        return False


def _metric_value(value: object) -> bool:
    return value is None or value in INFINITIES or _finite(value)


def _mapping_of(fits: Callable[[object], bool]) -> Callable[[object], bool]:
    """Whether a value is a JSON object whose every value ``fits``."""

    def check(value: object) -> bool:
        return isinstance(value, dict) and all(fits(v) for v in value.values())

    return check


#: A record's fields besides ``id`` and ``status``, each with the test its value passes.
_FIELDS: dict[str, Callable[[object], bool]] = {
    "message": lambda v: isinstance(v, str),
    "worker": lambda v: isinstance(v, str),
    "wall_time": lambda v: _finite(v) and isinstance(v, int | float) and v >= 0,
    "started": _finite,
    "metrics": _mapping_of(_metric_value),
    "checks": _mapping_of(lambda v: isinstance(v, bool)),
    "notes": _mapping_of(lambda v: isinstance(v, str)),
}
#: What each of :data:`_FIELDS` is, for :func:`record_problem`'s reason.
_FIELD_TYPES = {
    "message": "text",
    "worker": "text",
    "wall_time": "a number of seconds",
    "started": "a number",
    "metrics": "the metrics' values",
    "checks": "the checks' verdicts",
    "notes": "notes in text",
}


def _read_description(path: Path) -> dict[str, Any]:
    """``study.json`` (empty when it is no JSON object: it then matches no plan)."""
    data = _load(path)
    return data if isinstance(data, dict) else {}


def _number(value: object) -> float:
    """A number of a record as a float (NaN for anything else: a record may be edited); an
    infinite metric is written ``"inf"`` or ``"-inf"`` (strict JSON has no infinities)."""
    if value in INFINITIES:
        return float(str(value))
    if isinstance(value, int | float) and not isinstance(value, bool):
        try:
            return float(value)
        except OverflowError:  # an integer of hundreds of digits (JSON allows it)
            return math.nan
    return math.nan


def _mapping(value: object) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _write_results(path: Path, signals: dict[str, Any]) -> Path:
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
    return path


@contextlib.contextmanager
def _noted_whole(owned: OwnedFolder, written: list[Path]) -> Iterator[None]:
    """Write files and note them in the ownership record as one: a stop signal in between
    (Ctrl-C during a study) left a record written but not noted, which ``--force`` then
    refused as edited (the review of this change). The stop is held until the files written
    are noted, and raised then (:func:`~fmionnx.runtime.stopping.shield_begin`); what was
    written before an error is noted too."""
    shield_begin()
    try:
        yield
    finally:
        try:
            owned.note(written)
        finally:
            shield_end()
