"""One case, run on a worker: derive its system, run it in-process, measure, report.

Everything here runs in the worker process. The base compiled system arrives as JSON (read
once per worker and cached by content hash, with its models relocated into the worker's own
store), the case as a few settings. The case's system is :func:`apply_case` of the base; it
runs with the in-process backend, its FMUs isolated in processes of their own by default, so
an isolated model that crashes or hangs ends the case as a ``fault`` and never the worker. A
component in the worker's own process (not isolated) that crashes, or hangs past the step
timeout, takes the worker down: the case ends ``failed`` (see ``docs/sweep.md``). A case that
outlasts the study's timeout is stopped between steps (``timeout``). Whatever happens, the
worker returns a :class:`CaseOutcome`: a failing case never raises into the study.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.studyir import Case, Metric, StudyPlan, apply_case
from fmionnx.compile.systemfile import from_json, relocate
from fmionnx.core.processlocal import ProcessLocal
from fmionnx.core.types import PortRef

#: Runs one case's system and measures it (``system`` is the case's own, the case applied).
CaseRunner = Callable[[CompiledSystem, "Case", "Job"], "CaseOutcome"]

#: How a case ended. ``ok``: the run completed (its checks may still fail); ``fault``: a model
#: failed (or crashed, when isolated); ``timeout``: stopped after the study's timeout;
#: ``failed``: the case could not run at all (a setting that does not fit, the worker died).
CaseStatus = Literal["ok", "fault", "timeout", "failed"]


@dataclass(frozen=True)
class Job:
    """What every case of one study shares besides the system: metrics and run options."""

    metrics: tuple[Metric, ...]
    isolate: tuple[str, ...]
    timeout: float | None
    keep_results: bool = False
    #: Seconds one step may take (None: ``timeout``).
    step_timeout: float | None = None
    #: Keep each case's Rerun recording (``fmionnx sweep --rrd``): made on the worker, in
    #: memory, and written beside the case's results by the study's folder.
    rrd: bool = False

    @classmethod
    def of(cls, plan: StudyPlan, *, keep_results: bool = False, rrd: bool = False) -> Job:
        """The job of a compiled study: its metrics, isolation and timeouts."""
        return cls(plan.metrics, plan.isolate, plan.timeout, keep_results, plan.step_timeout, rrd)


@dataclass
class CaseOutcome:
    """What a case produced. ``metrics`` (None: no value, ``notes`` says why), each check's
    verdict, and with ``keep_results`` the recorded signals (``time`` first)."""

    id: str
    status: CaseStatus
    message: str = ""
    metrics: dict[str, float | None] = field(default_factory=dict)
    checks: dict[str, bool] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    wall_time: float = 0.0
    worker: str = ""
    #: When the case started on its worker (UNIX time, that machine's clock; its share of the
    #: batch's setup included): with ``wall_time``, the study's timeline.
    started: float = 0.0
    signals: dict[str, npt.NDArray[np.float64]] | None = None
    #: With ``rrd``: the case's Rerun recording (the bytes of an ``.rrd`` file).
    rrd: bytes | None = None

    def as_json(self) -> dict[str, object]:
        """The record written when the case finishes (``--resume`` reads it back).

        It is strict JSON, which has no infinities and no NaN: an infinite metric is the text
        ``"inf"`` or ``"-inf"`` (a value: the table holds it as a float), a NaN is ``null``
        with a note saying so, as every metric without a value has (docs/sweep.md).
        """
        data = dataclasses.asdict(self)
        data.pop("signals")
        data.pop("rrd")
        data["metrics"] = {k: json_metric(v) for k, v in self.metrics.items()}
        notes = dict(self.notes)
        for name, value in self.metrics.items():
            if value is not None and math.isnan(value):
                notes.setdefault(name, NAN_NOTE)
        data["notes"] = notes
        return data


#: Why a metric that measured NaN has no value in the table.
NAN_NOTE = "the measure is NaN (not a number: a NaN in what it reads, or 0/0)"


def json_metric(value: float | None) -> float | str | None:
    """A metric as a record holds it: a finite number as it is, an infinity as ``"inf"`` or
    ``"-inf"``, NaN (and no value) as None."""
    if value is None or math.isnan(value):
        return None
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


#: Base systems this worker has read, by the sha256 of their JSON, with models relocated into its store.
_SYSTEMS: dict[str, CompiledSystem] = {}
_SYSTEMS_LOCK = threading.Lock()
#: Whether :func:`freeze_once` froze this process's heap (a forked child's is its own).
_FROZEN: ProcessLocal[bool] = ProcessLocal()
#: What ``worker`` says of a case run outside a Dask worker.
LOCAL = "local"
#: The model store of a process that is not a Dask worker (made on first use).
_LOCAL_STORE: list[Path] = []


def worker_store() -> Path:
    """This worker's model store: in its local directory; off Dask (a plain loop in one
    process), in a scratch folder of this process, removed when it exits."""
    from fmionnx.backends.sweep.models import STORE_NAME

    try:
        from distributed import get_worker

        return Path(get_worker().local_directory) / STORE_NAME
    except ValueError:  # not inside a worker
        if not _LOCAL_STORE:
            from fmionnx.core.scratch import make_scratch

            _LOCAL_STORE.append(make_scratch("sweep-models"))
        return _LOCAL_STORE[0] / STORE_NAME


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except ValueError:
        return LOCAL


def base_system(text: str, models: Mapping[str, bytes], store: Path) -> CompiledSystem:
    """The base compiled system of ``text`` with its models in ``store`` (cached per process)."""
    from fmionnx.backends.sweep.models import unpack_models

    key = hashlib.sha256(text.encode()).hexdigest()
    with _SYSTEMS_LOCK:
        cached = _SYSTEMS.get(key)
        if cached is not None:
            return cached
        system = from_json(text, origin="the study's compiled system")
        unpack_models(store, models)
        system = relocate(system, store)
        _SYSTEMS[key] = system
        return system


def run_case(
    text: str, models: Mapping[str, bytes], case: Case, job: Job, runner: CaseRunner
) -> CaseOutcome:
    """Run ``case`` of the system ``text`` (models by hash) here; never raises."""
    return run_batch(text, models, (case,), job, runner)[0]


def run_batch(
    text: str,
    models: Mapping[str, bytes],
    cases: Sequence[Case],
    job: Job,
    runner: CaseRunner,
    budget: float | None = None,
) -> list[CaseOutcome]:
    """Run ``cases`` one after the other here, each exactly as it would run alone; never raises.

    One Dask task for several short cases: the task's own costs (the scheduler's round trip,
    the transfer, the driver's bookkeeping) are paid once for the batch, and so is finding the
    base system in this worker's cache. Each case keeps its own status, wall time, timeout and
    isolated processes, so a case that faults or times out ends only itself; the batch-mates
    after it still run. Only the death of this process (a crash of a component that is not
    isolated) loses the batch, and the driver then runs its cases again alone (:mod:`.engine`).

    With a ``budget`` (seconds), no case starts once the batch has run that long: the outcomes
    returned are those of the first cases, at least one, and the driver hands out the rest
    again (:mod:`.batching`).

    ``runner`` runs one case's system (the run pipeline's
    :func:`~fmionnx.pipeline.study.run_study_case`, handed down by the study's driver: a
    backend does not reach up to the pipeline itself).
    """
    one_core_per_case()
    worker = _worker_name()
    began = started = time.perf_counter()
    try:
        system: CompiledSystem | None = base_system(text, models, worker_store())
        problem = ""
    except Exception as exc:
        system, problem = None, f"{type(exc).__name__}: {exc}"
    setup = time.perf_counter() - began  # paid by the first case, as when it runs alone
    outcomes: list[CaseOutcome] = []
    for case in cases:
        if outcomes and budget is not None and time.perf_counter() - started > budget:
            break
        began = time.perf_counter()
        started_at = time.time() - setup  # the first case's setup counts as its own
        try:
            if system is None:
                outcome = CaseOutcome(case.id, "failed", problem)
            else:
                outcome = runner(apply_case(system, case), case, job)
        except Exception as exc:
            outcome = CaseOutcome(case.id, "failed", f"{type(exc).__name__}: {exc}")
        outcome.wall_time = time.perf_counter() - began + setup
        outcome.worker = worker
        outcome.started = started_at
        outcomes.append(outcome)
        setup = 0.0
    if worker != LOCAL:
        freeze_once()
    return outcomes


#: Mesa's software renderer (llvmpipe) starts a thread per core unless told otherwise.
RENDER_THREADS = "LP_NUM_THREADS"


def one_core_per_case() -> None:
    """Let each case of this process use one core, as Dask's workers do for BLAS and OpenMP.

    A sweep's parallelism is across cases: with as many cases running as cores, a case that
    also fans out -- onnxruntime's thread pool, the software renderer's threads, an isolated
    child spinning while it waits -- takes a core from another case. Measured on the reference
    scenario: 2 workers ran 20 cases in 22.4 s one core each, 26.2 s without (docs/sweep.md).
    An ONNX component's own ``threads`` and a ``LP_NUM_THREADS`` already set are kept.
    """
    from fmionnx.kinds.registry import settle_worker
    from fmionnx.runtime.isolated.proxy import keep_children, one_core_each

    os.environ.setdefault(RENDER_THREADS, "1")
    settle_worker()  # e.g. one onnxruntime thread each, FMU libraries kept for the next case
    one_core_each()
    keep_children()  # an isolated model's process serves its next cases


def freeze_once() -> None:
    """Exempt what this worker holds after its first batch from the cyclic garbage collector.

    By then the worker has imported what a case needs, read the compiled system and loaded its
    models, and none of it is garbage. Left in the collector's oldest generation, all of it
    (a Dask worker's whole heap) is walked by every full collection: 30-40 ms, as long as
    forty short cases, now and then in the middle of one. Objects made later are collected as
    usual. Once per process.
    """
    import gc

    if _FROZEN.get():
        return
    gc.collect()
    gc.freeze()
    _FROZEN.get_or_make(lambda: True)


def record_refs(system: CompiledSystem, job: Job) -> tuple[PortRef, ...]:
    """What a case records: what the metrics and checks measure, and with ``keep_results``
    what a plain run records."""
    from fmionnx.runtime.master import default_record, required_refs

    refs: list[PortRef] = [ref for m in job.metrics for ref in m.refs]
    refs.extend(ref for check in system.checks for ref in check.refs)
    if job.keep_results:
        refs = [*(system.record or default_record(system)), *required_refs(system), *refs]
    return tuple(dict.fromkeys(refs))
