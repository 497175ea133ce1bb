"""A study's case, run through the run pipeline on a worker.

The sweep backend (:mod:`fmionnx.backends.sweep`) ships a study's compiled system and cases to
its workers; each case's system (:func:`~fmionnx.compile.studyir.apply_case` of the base) is
run here like any run: a request with the study's isolation, its step timeout and no results
folder, the in-process backend from the backend table, its ``prepare`` and ``validate``, the
system's checks. What a case adds is measuring its metrics and the study's timeout, which
stops it between steps.
"""

from __future__ import annotations

import functools
import math
import time
from pathlib import Path

from fmionnx.backends.sweep.case import CaseOutcome, CaseStatus, Job, record_refs
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.studyir import Case
from fmionnx.pipeline.errors import PipelineError
from fmionnx.pipeline.observers import RunObserver
from fmionnx.pipeline.request import RunRequest, build_request
from fmionnx.pipeline.run import execute
from fmionnx.pipeline.system import System
from fmionnx.runtime.checks import CheckOutcome, MeasureError, measure
from fmionnx.runtime.result import RunResult, RunStatus


class _Deadline(KeyboardInterrupt):
    """The study's timeout for a case ran out: stops the master between two steps."""


class _Timeout(RunObserver):
    """Stops the case (between steps) once it has run ``seconds`` of wall time."""

    wants_progress = True
    #: Often enough that a short case is stopped near its timeout, rarely enough to cost nothing.
    progress_every = 20

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.expired = False
        self._started = time.perf_counter()

    def progress(self, done: int, total: int, time_reached: float) -> None:
        """Raise :class:`_Deadline` once the time is up."""
        if time.perf_counter() - self._started > self.seconds:
            self.expired = True
            raise _Deadline


@functools.lru_cache(maxsize=16)
def case_request(job: Job, name: str) -> RunRequest:
    """The request every case of ``job`` runs with (made once per worker: a study's cases can
    be a millisecond each)."""
    timeout = job.step_timeout if job.step_timeout is not None else job.timeout
    return build_request(
        Path(name), isolate=list(job.isolate) or ["none"], schedule="sequential",
        step_timeout=timeout if timeout is not None else math.inf, no_out=True,
    )  # fmt: skip


def run_study_case(system: CompiledSystem, case: Case, job: Job) -> CaseOutcome:
    """Run ``case`` (``system`` is its system, the case applied) and measure it."""
    request = case_request(job, system.name)
    watch: list[RunObserver] = [_Timeout(job.timeout)] if job.timeout is not None else []
    view = None
    if job.rrd:
        from fmionnx.pipeline.views.rerun_view import RerunView

        view = RerunView(None, None, memory=True)
    try:
        outcome = execute(
            request, [*watch, *([view] if view else [])], system=System(system),
            signals=record_refs(system, job),
        )  # fmt: skip
    except PipelineError as exc:  # e.g. an external component, which only ROS 2 provides
        return CaseOutcome(case.id, "failed", str(exc))
    result = outcome.result
    status: CaseStatus = "ok"
    message = ""
    if result.status is RunStatus.FAULT:
        status, message = "fault", str(result.error) if result.error else "fault"
    elif watch and isinstance(watch[0], _Timeout) and watch[0].expired:
        status = "timeout"
        message = (
            f"stopped after the study's timeout of {job.timeout:g} s at t={result.time[-1]:g} s"
        )
    elif result.status is not RunStatus.COMPLETED:
        status, message = "failed", f"the run ended {result.status.value}"
    measured = _measured(CaseOutcome(case.id, status, message), outcome.checks, result, job)
    if view is not None:
        measured.rrd = view.data
    return measured


def _measured(
    outcome: CaseOutcome, checks: tuple[CheckOutcome, ...], result: RunResult, job: Job
) -> CaseOutcome:
    """``outcome`` with the study's metrics measured and every check's verdict."""
    for metric in job.metrics:
        try:
            outcome.metrics[metric.name] = measure(metric.measure, result)
        except MeasureError as exc:
            outcome.metrics[metric.name] = None
            outcome.notes[metric.name] = str(exc)
    for verdict in checks:
        outcome.checks[verdict.name] = verdict.passed and outcome.status == "ok"
        if verdict.note and not verdict.passed:
            outcome.notes[verdict.name] = verdict.note
    if job.keep_results:
        outcome.signals = {"time": result.time, **result.signals}
    return outcome
