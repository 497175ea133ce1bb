"""A study's worker keeps an isolated model's process for the model's next case
(fmionnx/runtime/isolated/proxy.py, ``keep_children``): the next case makes a new instance in
it. Only after a clean end -- a case that crashes, hangs or faults its model never gives its
process back, so the next case gets a fresh one and the crash stays that case's fault -- only
for models that may be instantiated more than once per process, only in the process that
asked; and every case's results are those of a run in fresh processes."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from fmionnx.backends.sweep.case import CaseOutcome, Job, run_batch
from fmionnx.backends.sweep.models import pack_models
from fmionnx.compile.studyir import apply_case
from fmionnx.compile.systemfile import to_json
from fmionnx.kinds.fmu.libraries import stop_keeping_libraries
from fmionnx.pipeline.study import run_study_case
from fmionnx.pipeline.sweep import plan_study
from fmionnx.runtime.isolated import proxy
from tests.backends.test_library_pool import _with_description_flag
from tests.conftest import drop_worker_state
from tests.sweep.test_failures import SYSTEM as FAULTY_SYSTEM

SYSTEM = """\
fmionnx: 1
name: kept
run: {stop: 1, step: 0.01}
components:
  src: {kind: signal, outputs: {y: {sine: {frequency: 1}}}}
  gain: {kind: fmu, path: Gain.fmu, parameters: {v: [0, 0, 0]}}
  integrator: {kind: fmu, path: Integrator.fmu}
connections:
  - src.y -> gain.u
  - gain.y -> integrator.u
"""

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [fmus]
parameters:
  gain.k: [0.5, 1, 2, 0.5]
metrics:
  peak: max(gain.y)
  end: final(integrator.x)
"""


@pytest.fixture
def fresh_process_state() -> Iterator[None]:
    """No kept children (nor libraries) before or after the test: they belong to the process."""
    drop_worker_state()
    yield
    drop_worker_state()


def kept_children() -> dict[str, int]:
    """Model file name -> process id of each child kept idle in this process."""
    pool = proxy._children.get()
    assert pool is not None
    return {Path(child.key[2]).name: child.process.pid for child in pool._idle}


def one_by_one(folder: Path, system: str, study: str) -> list[tuple[CaseOutcome, dict[str, int]]]:
    """Each case of the study as a task of its own in this process (a worker's life), with the
    children kept after it."""
    (folder / "system.yaml").write_text(system, encoding="utf-8")
    (folder / "study.yaml").write_text(study, encoding="utf-8")
    plan = plan_study(folder / "study.yaml")[0]
    text, models, job = to_json(plan.system), pack_models(plan.system), Job.of(plan)
    done = []
    for case in plan.cases:
        (outcome,) = run_batch(text, models, (case,), job, run_study_case)
        done.append((outcome, kept_children()))
    return done


def in_fresh_processes(folder: Path) -> list[dict[str, float | None]]:
    """Every case run as ``fmionnx run`` runs it: fresh isolated processes, nothing kept."""
    plan = plan_study(folder / "study.yaml")[0]
    job = Job.of(plan)
    assert proxy._children.get() is None
    return [run_study_case(apply_case(plan.system, c), c, job).metrics for c in plan.cases]


def test_the_next_case_runs_in_the_same_processes_with_the_same_results(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    for name in ("Gain", "Integrator"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    done = one_by_one(tmp_path, SYSTEM, STUDY)
    assert [o.status for o, _ in done] == ["ok"] * 4
    first = done[0][1]
    assert set(first) == {"Gain.fmu", "Integrator.fmu"}
    assert all(children == first for _, children in done)  # the same two processes each case
    kept = [o.metrics for o, _ in done]
    own_pid = os.getpid()
    assert own_pid not in first.values()  # children, not this process
    pool = proxy._children.clear()
    assert pool is not None
    pool.close()
    stop_keeping_libraries()
    assert kept == in_fresh_processes(tmp_path)
    assert kept[0] == kept[3]  # case 4 repeats case 1's k in a process that ran 3 cases


FAULTY_STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [fmus]
step_timeout: 10
parameters:
  bad.failAt: [5, 0.3, 5, 5]
  bad.mode: [{mode}]
metrics:
  y_end: final(gain.y)
"""


@pytest.mark.parametrize(("mode", "how"), [(3, "segfault"), (0, "FMI error"), (6, "hang")])
def test_a_case_that_breaks_its_model_gives_no_process_back(
    tmp_path: Path,
    fixture_fmu: Callable[[str], Path],
    fresh_process_state: None,
    mode: int,
    how: str,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Cases 1, 3 and 4 run cleanly, case 2 crashes, errs or hangs (killed at the step
    timeout) at t = 0.3: it is a fault of that case alone; its process is not kept, so
    case 3 starts a fresh one, which case 4 then reuses; every result is a fresh run's."""
    for name in ("Faulty", "Gain"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    study = FAULTY_STUDY.format(mode=mode)
    if how == "hang":
        study = study.replace("step_timeout: 10", "step_timeout: 1")
    done = one_by_one(tmp_path, FAULTY_SYSTEM, study)
    statuses = [o.status for o, _ in done]
    assert statuses == ["ok", "fault", "ok", "ok"], [o.message for o, _ in done]
    assert "bad" in done[1][0].message
    bad = [children.get("Faulty.fmu") for _, children in done]
    assert bad[1] is None  # the broken case kept nothing of its Faulty model
    assert bad[0] is not None
    assert bad[2] is not None
    assert bad[2] != bad[0]  # a fresh process after the fault ...
    assert bad[3] == bad[2]  # ... kept again once its case ended cleanly
    metrics = [o.metrics for o, _ in done]
    pool = proxy._children.clear()
    assert pool is not None
    pool.close()
    stop_keeping_libraries()
    assert metrics == in_fresh_processes(tmp_path)


def test_a_model_allowed_one_instance_per_process_gets_a_fresh_process_every_case(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    _with_description_flag(
        fixture_fmu("Gain"), tmp_path / "Gain.fmu", 'canBeInstantiatedOnlyOncePerProcess="true"'
    )
    shutil.copy(fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    done = one_by_one(tmp_path, SYSTEM, STUDY)
    assert [o.status for o, _ in done] == ["ok"] * 4
    assert all("Gain.fmu" not in children for _, children in done)
    assert all("Integrator.fmu" in children for _, children in done)


def test_without_keep_children_every_run_ends_its_processes(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    """``fmionnx run`` and the Python API: a run's isolated processes end with it."""
    import fmionnx

    for name in ("Gain", "Integrator"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    result = fmionnx.load(tmp_path / "system.yaml").run(isolate="fmus")
    assert result.status.value == "completed"
    assert proxy._children.get() is None


def test_a_forked_process_does_not_use_its_parents_children(fresh_process_state: None) -> None:
    proxy.keep_children()
    pid = os.fork()
    if pid == 0:  # the child (a guardian's run): its own runs start their own processes
        os._exit(0 if proxy._children.get() is None else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert proxy._children.get() is not None
