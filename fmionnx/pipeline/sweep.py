"""Running a study end to end: study file -> plan -> cases on a Dask cluster -> results folder.

What ``fmionnx sweep`` and :func:`fmionnx.sweep` both do. The study is compiled first (every
problem is a diagnostic, nothing is written); then the results folder is prepared (a resumed
study keeps its finished cases), the remaining cases run on the cluster, each outcome is
recorded the moment it arrives, and finally the table and the plots are written from the
records.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import StudyPlan
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Severity
from fmionnx.core.errors import DiagnosticError

if TYPE_CHECKING:
    import pandas as pd

    from fmionnx.backends.sweep.case import CaseOutcome
    from fmionnx.backends.sweep.engine import StudyRun

#: ``progress(done, failed, total)``: after every finished case (and once before the first).
SweepProgress = Callable[[int, int, int], None]


@dataclass(frozen=True)
class SweepResult:
    """A finished study: its plan, the table, the files written, the cases skipped (resume),
    and how the cases run this time were cut into Dask tasks (None: none ran)."""

    plan: StudyPlan
    table: pd.DataFrame
    files: tuple[Path, ...]
    resumed: int
    warnings: tuple[Diagnostic, ...] = ()
    tasks: StudyRun | None = None


def plan_study(study: str | Path) -> tuple[StudyPlan, tuple[Diagnostic, ...]]:
    """Compile a study file; raises DiagnosticError with every error."""
    from fmionnx.compile.study import compile_study
    from fmionnx.spec.study import load_study

    bag = DiagnosticBag()
    plan = compile_study(load_study(Path(study), bag), bag)
    diagnostics = tuple(bag.sorted())
    errors = [d for d in diagnostics if d.severity is Severity.ERROR]
    if plan is None or errors:
        raise DiagnosticError(errors)
    return plan, diagnostics


def sweep_study(
    study: str | Path,
    out: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    keep_results: bool = False,
    force: bool = False,
    progress: SweepProgress | None = None,
    batch: int | None = None,
    warnings: Callable[[tuple[Diagnostic, ...]], None] | None = None,
    rrd: bool = False,
) -> SweepResult:
    """``fmionnx sweep`` and :func:`fmionnx.sweep`: check the request, compile the study,
    run it into ``out``.

    Options that exclude each other, a scheduler address that is not one and an unusable
    folder are :class:`~fmionnx.pipeline.errors.RequestError` (exit 2) before anything runs;
    errors in the study file DiagnosticError; a folder holding another study
    ``StudyFolderError``; a cluster that cannot be reached or started ``SchedulerError`` or
    ``ClusterStartError`` (a folder made for the study is removed again). ``warnings``
    receives the study's warnings before the cases run.
    """
    from fmionnx.backends.sweep.engine import ClusterStartError, SchedulerError, scheduler_problem
    from fmionnx.pipeline.errors import RequestError
    from fmionnx.pipeline.outputs import check_output_folder

    if resume and force:
        msg = "--resume keeps the finished cases, --force removes them: choose one"
        raise RequestError(msg)
    if workers is not None and scheduler is not None:
        msg = "--workers starts a local cluster; an existing one (--scheduler) has its own"
        raise RequestError(msg)
    if rrd:
        from fmionnx.pipeline.views import ViewUnavailableError, require_rerun

        try:
            require_rerun("--rrd")
        except ViewUnavailableError as exc:
            raise RequestError(str(exc)) from None
    plan, diagnostics = plan_study(study)
    found = tuple(d for d in diagnostics if d.severity is not Severity.ERROR)
    if found and warnings is not None:
        warnings(found)
    problem = None if scheduler is None else scheduler_problem(scheduler)
    if problem is not None:
        raise RequestError(problem)
    made_out = not out.exists()
    check_output_folder(out, "--out")
    try:
        return run_sweep(
            plan, out, scheduler=scheduler, workers=workers, resume=resume,
            keep_results=keep_results, force=force, progress=progress, batch=batch, rrd=rrd,
        )  # fmt: skip
    except (SchedulerError, ClusterStartError):
        if made_out:  # made just now and still empty: no trace of a study that never started
            with contextlib.suppress(OSError):
                out.rmdir()
        raise


def run_sweep(
    plan: StudyPlan,
    out: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    keep_results: bool = False,
    force: bool = False,
    progress: SweepProgress | None = None,
    batch: int | None = None,
    rrd: bool = False,
) -> SweepResult:
    """Run ``plan``'s cases not yet recorded in ``out``; write the table and the plots.

    ``force`` replaces the results of a study already in ``out`` (without: refused).
    ``batch`` fixes the cases per Dask task (1: one each; None: sized from the case times).
    """
    from fmionnx.backends.sweep.engine import open_client, refuse_in_starting_worker
    from fmionnx.results.study import StudyFolder, StudyFolderError

    refuse_in_starting_worker()  # before the folder is touched
    problem = StudyFolder(out, plan).problem(resume=resume, force=force)
    if problem is not None:  # said at once, not after starting a cluster
        raise StudyFolderError(problem)
    with contextlib.ExitStack() as stack:
        # The cluster is reached (an existing one) or started (a local one) before the folder
        # is touched: a wrong address, a scheduler that does not answer or workers that cannot
        # start leave nothing behind to be --resume'd, and --force has removed nothing. A
        # resumed study, which removes nothing, starts a local cluster only if cases are left.
        client = None
        if scheduler is not None or not resume:
            client = stack.enter_context(open_client(scheduler, workers))
        return _run(plan, out, client, workers, resume, keep_results, force, progress, batch, rrd)


def _run(
    plan: StudyPlan,
    out: Path,
    client: Any,
    workers: int | None,
    resume: bool,
    keep_results: bool,
    force: bool,
    progress: SweepProgress | None,
    batch: int | None,
    rrd: bool = False,
) -> SweepResult:
    from fmionnx.backends.sweep.case import Job
    from fmionnx.backends.sweep.engine import open_client, run_study
    from fmionnx.pipeline.study import run_study_case
    from fmionnx.results.study import StudyFolder
    from fmionnx.results.study_plots import write_study_plots

    folder = StudyFolder(out, plan)
    finished = folder.prepare(resume=resume, force=force)
    pending = [c for c in plan.cases if c.id not in finished]
    job = Job.of(plan, keep_results=keep_results, rrd=rrd)
    counts = [len(finished), 0]
    if progress is not None:
        progress(counts[0], counts[1], len(plan.cases))

    def on_done(outcome: CaseOutcome) -> None:
        folder.record(outcome)
        counts[0] += 1
        counts[1] += outcome.status != "ok"
        if progress is not None:
            progress(counts[0], counts[1], len(plan.cases))

    tasks = None
    if pending and client is not None:
        tasks = run_study(client, plan, pending, job, on_done, run_study_case, batch=batch)
    elif pending:  # a resumed study with cases left
        with open_client(None, workers) as started:
            tasks = run_study(started, plan, pending, job, on_done, run_study_case, batch=batch)
    table = folder.table()
    files = folder.write_table(table)
    files.extend(write_study_plots(table, plan, out))
    return SweepResult(plan, table, tuple(files), len(finished), tasks=tasks)
