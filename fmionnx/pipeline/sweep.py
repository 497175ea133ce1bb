"""Running a study end to end: study file -> plan -> cases on a Dask cluster -> results folder.

What ``fmionnx sweep`` and :func:`fmionnx.sweep` both do. The study is compiled first (every
problem is a diagnostic, nothing is written); then the results folder is prepared (a resumed
study keeps its finished cases), the remaining cases run on the cluster, each outcome is
recorded the moment it arrives, and finally the table and the plots are written from the
records.
"""

from __future__ import annotations

import contextlib
import functools
import threading
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
    from fmionnx.results.casetable import CaseTable
    from fmionnx.spec.study import LoadedStudy

#: ``progress(done, failed, total)``: after every finished case (and once before the first).
SweepProgress = Callable[[int, int, int], None]


@dataclass(frozen=True)
class SweepResult:
    """A finished study: its plan, the table, the files written, the cases skipped (resume),
    and how the cases run this time were cut into Dask tasks (None: none ran)."""

    plan: StudyPlan
    cases: CaseTable
    files: tuple[Path, ...]
    resumed: int
    warnings: tuple[Diagnostic, ...] = ()
    tasks: StudyRun | None = None
    #: Cases whose record was there but damaged (``--resume``): they ran again.
    damaged: int = 0

    @functools.cached_property
    def table(self) -> pd.DataFrame:
        """The table as a DataFrame (pandas is imported for it: the command does without)."""
        return self.cases.to_pandas()


def plan_study(study: str | Path) -> tuple[StudyPlan, tuple[Diagnostic, ...]]:
    """Compile a study file, or read its compile back from the compile cache; raises
    DiagnosticError with every error."""
    return _StudySource(Path(study)).plan()


class _StudySource:
    """A study file about to be compiled: its plan kept in the compile cache
    (:mod:`fmionnx.pipeline.keptstudy`), or the file read (its own problems in a bag) and its
    system not compiled yet."""

    def __init__(self, study: Path) -> None:
        from fmionnx.pipeline.keptstudy import kept_plan, plan_slot

        self.place = plan_slot(study)
        self.kept = kept_plan(self.place)
        self.bag = DiagnosticBag()
        self.loaded: LoadedStudy | None = None
        if self.kept is None:
            from fmionnx.spec.study import load_study

            self.loaded = load_study(study, self.bag)

    @property
    def readable(self) -> bool:
        """Whether the study file itself has no error (its system may still have some)."""
        if self.loaded is None:
            return True
        return not self.bag.has_errors and self.loaded.spec is not None

    def plan(self) -> tuple[StudyPlan, tuple[Diagnostic, ...]]:
        """The plan and its warnings: its system compiled (through the compile cache)."""
        if self.kept is not None:
            return self.kept.plan, self.kept.diagnostics
        from fmionnx.pipeline.keptstudy import compiled_plan

        assert self.loaded is not None  # read when no plan was kept
        plan, diagnostics = compiled_plan(self.loaded, self.bag, self.place)
        if plan is None:
            raise DiagnosticError([d for d in diagnostics if d.severity is Severity.ERROR])
        return plan, diagnostics


def _count(value: object, option: str, what: str) -> int | None:
    """A count of at least one (``--workers``, ``--batch``), checked here for the CLI and
    :func:`fmionnx.sweep` alike: ``workers=0`` ran a study without a word (a bug hunt)."""
    import operator

    from fmionnx.pipeline.errors import RequestError

    if value is None:
        return None
    count = None
    if not isinstance(value, bool) and hasattr(value, "__index__"):
        count = operator.index(value)  # an int, or a numpy integer
    if count is None or count < 1:
        msg = f"{option} takes a whole number of {what}, at least 1, not `{value}`"
        raise RequestError(msg)
    return count


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
    client: Any = None,
) -> SweepResult:
    """``fmionnx sweep`` and :func:`fmionnx.sweep`: check the request, compile the study,
    run it into ``out``.

    Options that exclude each other, a scheduler address that is not one and an unusable
    folder are :class:`~fmionnx.pipeline.errors.RequestError` (exit 2) before anything runs;
    errors in the study file DiagnosticError; a folder holding another study
    ``StudyFolderError``; a cluster that cannot be reached or started ``SchedulerError`` or
    ``ClusterStartError`` (a folder made for the study is removed again). ``warnings``
    receives the study's warnings before the cases run. ``client``: a Dask client of the
    caller's, used as it is and left open (one client for many studies).

    A new local cluster starts while the study compiles (its workers need seconds to start),
    and is closed while the table and plots are written: see :class:`StudyCluster`.
    """
    from fmionnx.backends.sweep.engine import (
        ClusterStartError,
        SchedulerError,
        refuse_in_starting_worker,
    )
    from fmionnx.pipeline.errors import RequestError

    if resume and force:
        msg = "--resume keeps the finished cases, --force removes them: choose one"
        raise RequestError(msg)
    workers = _count(workers, "--workers", "local worker processes")
    batch = _count(batch, "--batch", "cases per Dask task")
    if workers is not None and scheduler is not None:
        msg = "--workers starts a local cluster; an existing one (--scheduler) has its own"
        raise RequestError(msg)
    if client is not None and (workers is not None or scheduler is not None):
        msg = "`client` is the cluster to run on: not with `workers` or `scheduler`"
        raise RequestError(msg)
    if rrd:
        from fmionnx.pipeline.views import ViewUnavailableError, require_rerun

        try:
            require_rerun("--rrd")
        except ViewUnavailableError as exc:
            raise RequestError(str(exc)) from None
    refuse_in_starting_worker()
    source = _StudySource(Path(study))
    # A local cluster starts now, while the system compiles, unless the study file itself is
    # wrong (its errors are said at once) or a resumed study may have nothing left to run.
    start_now = not resume and source.readable
    cluster = StudyCluster(scheduler, workers, client, start_now=start_now)
    # While a local cluster starts (seconds), the table's and plots' libraries load too: a
    # study of short cases would otherwise wait for them after its last case. On a cluster
    # that is up already they load with the cases, not against the compile.
    local = start_now and scheduler is None and client is None
    writers = _ResultsWriters() if local else None
    try:
        try:
            plan, made_out = _checked_plan(source, out, scheduler, warnings)
        except BaseException:
            cluster.release(wait=True)  # a system with errors: no cluster left behind
            raise
        try:
            return run_sweep(
                plan, out, resume=resume, keep_results=keep_results, force=force,
                progress=progress, batch=batch, cluster=cluster, rrd=rrd, writers=writers,
            )  # fmt: skip
        except (SchedulerError, ClusterStartError):
            if made_out:  # made just now and still empty: no trace of a study never started
                with contextlib.suppress(OSError):
                    out.rmdir()
            raise
    finally:
        if writers is not None:
            writers.close()  # its plot worker, when the study stopped before its plots


def _checked_plan(
    source: _StudySource,
    out: Path,
    scheduler: str | None,
    warnings: Callable[[tuple[Diagnostic, ...]], None] | None,
) -> tuple[StudyPlan, bool]:
    """The study compiled, its warnings handed on, the scheduler address and ``out`` checked;
    and whether ``out`` was made just now."""
    from fmionnx.backends.sweep.engine import scheduler_problem
    from fmionnx.pipeline.errors import RequestError
    from fmionnx.pipeline.outputs import check_output_folder

    plan, diagnostics = source.plan()
    found = tuple(d for d in diagnostics if d.severity is not Severity.ERROR)
    if found and warnings is not None:
        warnings(found)
    problem = None if scheduler is None else scheduler_problem(scheduler)
    if problem is not None:
        raise RequestError(problem)
    made_out = not out.exists()
    check_output_folder(out, "--out")
    return plan, made_out


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
    cluster: StudyCluster | None = None,
    writers: _ResultsWriters | None = None,
) -> SweepResult:
    """Run ``plan``'s cases not yet recorded in ``out``; write the table and the plots.

    ``force`` replaces the results of a study already in ``out`` (without: refused; with it,
    refused too where a file the study writes again was edited since, which it would write
    over: :meth:`~fmionnx.results.study.StudyFolder.kept_in_the_way`).
    ``batch`` fixes the cases per Dask task (1: one each; None: sized from the case times).
    ``cluster``: where to run (default: ``scheduler``'s cluster, else a new local one of
    ``workers`` processes, started only if cases are left for a resumed study).
    ``writers``: the table's and plots' libraries, loading since the study began (default:
    they start loading with the cases).
    """
    from fmionnx.backends.sweep.engine import refuse_in_starting_worker
    from fmionnx.results.study import StudyFolder, StudyFolderError

    refuse_in_starting_worker()  # before the folder is touched
    if cluster is None:
        cluster = StudyCluster(scheduler, workers, None, start_now=False)
    try:
        folder = StudyFolder(out, plan)
        problem = folder.problem(resume=resume, force=force)
        if problem is None and (force or resume):  # a table edited since: kept, so refused
            problem = folder.kept_in_the_way(resume=resume and not force)
        if problem is not None:  # said at once, not after starting a cluster
            raise StudyFolderError(problem)
        # The cluster is reached (an existing one) or started (a local one) before the folder
        # is touched: a wrong address, a scheduler that does not answer or workers that cannot
        # start leave nothing behind to be --resume'd, and --force has removed nothing. A
        # resumed study, which removes nothing, starts a local cluster only if cases are left.
        if not resume:
            cluster.client()
        return _run(plan, out, cluster, resume, keep_results, force, progress, batch, rrd, writers)
    finally:
        cluster.release(wait=True)


def _run(
    plan: StudyPlan,
    out: Path,
    cluster: StudyCluster,
    resume: bool,
    keep_results: bool,
    force: bool,
    progress: SweepProgress | None,
    batch: int | None,
    rrd: bool = False,
    writers: _ResultsWriters | None = None,
) -> SweepResult:
    from fmionnx.backends.sweep.case import Job
    from fmionnx.backends.sweep.engine import run_study
    from fmionnx.pipeline.study import run_study_case
    from fmionnx.results.study import StudyFolder

    folder = StudyFolder(out, plan)
    finished = folder.prepare(resume=resume, force=force)
    pending = [c for c in plan.cases if c.id not in finished]
    # a record there that does not check out is run again: said, so nobody wonders why
    damaged = sum((folder.records / f"{c.id}.json").exists() for c in pending) if resume else 0
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

    if writers is None:
        writers = _ResultsWriters()  # their libraries load while the cases run
    try:
        tasks = None
        if pending:
            tasks = run_study(
                cluster.client(), plan, pending, job, on_done, run_study_case, batch=batch
            )
        cluster.release(wait=False)  # a local cluster ends while the table and plots are written
        writers.ready()
        table = folder.table()
        writers.submit(table, plan, out)  # the worker draws the plots while the table is written
        files = folder.write_table(table)
        files.extend(writers.plots(table, plan, out))
    finally:
        writers.close()  # its plot worker, when the study stopped before its plots
    return SweepResult(plan, table, tuple(files), len(finished), tasks=tasks, damaged=damaged)


class _ResultsWriters:
    """The table's library (pyarrow) imported on a thread of their own while the
    cases run, instead of after the last one; and a plot worker started meanwhile
    (:mod:`fmionnx.results.plotworker`), which imports matplotlib and then draws the study's
    plots side by side while this process writes the table. Without a worker (one core,
    ``FMIONNX_PLOT_WORKER=0``, or it failed), the plots are drawn here, as before."""

    def __init__(self) -> None:
        from fmionnx.results import plotworker

        self._plotter = plotworker.start(study=True)
        self._submitted = False
        self._thread = threading.Thread(
            target=self._load, name="fmionnx-study-writers", daemon=True
        )
        self._thread.start()

    def _load(self) -> None:
        # Whatever goes wrong here (a library missing, an import racing another thread's), the
        # import after the cases, on the study's own thread, says so.
        with contextlib.suppress(Exception):
            import pyarrow.parquet  # noqa: F401

            if self._plotter is None:
                from matplotlib.figure import Figure  # noqa: F401

                import fmionnx.results.study_plots  # noqa: F401

    def ready(self) -> None:
        """Wait for the imports (an import in two threads at once waits anyway)."""
        self._thread.join()

    def submit(self, table: CaseTable, plan: StudyPlan, out: Path) -> None:
        """Hand the plots to the worker, which draws them while the table is written."""
        from fmionnx.results.plotworker import StudyPlotJob

        plotter = self._plotter
        self._submitted = plotter is not None and plotter.submit(StudyPlotJob(table, plan, out))

    def plots(self, table: CaseTable, plan: StudyPlan, out: Path) -> list[Path]:
        """The study's plots: the worker's, once drawn, else drawn here."""
        from fmionnx.core.owned import OwnedFolder
        from fmionnx.results.study_plots import write_study_plots

        plotter, self._plotter = self._plotter, None
        drawn = plotter.collect() if plotter is not None and self._submitted else None
        if plotter is not None:
            plotter.close()
        if drawn is None:
            return write_study_plots(table, plan, out)
        OwnedFolder(out).note(drawn)  # a later --force may delete them (fmionnx.core.owned)
        return drawn

    def close(self) -> None:
        """End an unused worker (a study that stopped before its plots)."""
        plotter, self._plotter = self._plotter, None
        if plotter is not None:
            plotter.close()


class StudyCluster:
    """The Dask client a study runs on, started early and closed late.

    * With a ``client`` of the caller's: that client, left open.
    * With a ``scheduler`` address: this process's client of that cluster
      (:func:`~fmionnx.backends.sweep.engine.shared_client`), kept open for the next study on
      it (a cluster stays warm between the studies of one Python process).
    * Otherwise a new local cluster. With ``start_now`` it starts on a thread of its own at
      once -- its workers take seconds to start, the study meanwhile compiles -- and
      :meth:`client` waits for it. :meth:`release` closes it, on a thread of its own unless
      asked to wait: the last cases have returned, and the table and plots are written while
      the workers end.
    """

    def __init__(
        self, scheduler: str | None, workers: int | None, client: Any, *, start_now: bool
    ) -> None:
        self._scheduler = scheduler
        self._workers = workers
        self._given = client
        self._client: Any = None
        self._error: BaseException | None = None
        self._stack: contextlib.ExitStack | None = None
        self._started: threading.Thread | None = None
        self._closing: threading.Thread | None = None
        self._lock = threading.Lock()
        if start_now and client is None and scheduler is None:
            self._started = threading.Thread(
                target=self._start, name="fmionnx-cluster-start", daemon=True
            )
            self._started.start()

    def _start(self) -> None:
        from fmionnx.backends.sweep.engine import open_client

        stack = contextlib.ExitStack()
        try:
            self._client = stack.enter_context(open_client(None, self._workers))
        except BaseException as exc:  # handed to the thread that asks for the client
            self._error = exc
        else:
            self._stack = stack

    def client(self) -> Any:
        """The client (a local cluster is started now if it has not been)."""
        from fmionnx.backends.sweep.engine import shared_client

        if self._given is not None:
            return self._given
        if self._scheduler is not None:
            return shared_client(self._scheduler)
        with self._lock:
            if self._started is None:
                self._start()
            else:
                self._started.join()
            if self._error is not None:
                raise self._error
            return self._client

    def release(self, *, wait: bool) -> None:
        """Close a local cluster this study started (in the background unless ``wait``); an
        existing cluster's or the caller's client stays open."""
        with self._lock:
            if self._closing is None and (self._stack is not None or self._started is not None):
                self._closing = threading.Thread(
                    target=self._close, name="fmionnx-cluster-close", daemon=False
                )
                self._closing.start()
            closing = self._closing
        if wait and closing is not None:
            closing.join()

    def _close(self) -> None:
        if self._started is not None:
            self._started.join()
        stack, self._stack = self._stack, None
        if stack is not None:
            with contextlib.suppress(Exception):  # a cluster that fails to close ends with us
                stack.close()
