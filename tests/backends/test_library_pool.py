"""A sweep worker keeps an FMU's unpacked files and loaded library between its cases
(fmionnx/kinds/fmu/libraries.py): the next case makes only a new instance. Only after a clean
end, only for FMUs that allow several instances per process, only in the process that asked;
and a case's results are those of a run without it."""

from __future__ import annotations

import os
import shutil
import threading
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from fmionnx.backends.sweep.case import CaseOutcome, Job, run_batch
from fmionnx.backends.sweep.models import pack_models
from fmionnx.compile.systemfile import to_json
from fmionnx.kinds.fmu.libraries import (
    LibraryPool,
    LoadedFmu,
    active_pool,
    keep_libraries,
    stop_keeping_libraries,
)
from fmionnx.pipeline.study import run_study_case
from fmionnx.pipeline.sweep import plan_study
from tests.conftest import drop_worker_state
from tests.sweep.test_failures import SYSTEM as FAULTY_SYSTEM

SYSTEM = """\
fmionnx: 1
name: pooled
run: {stop: 1, step: 0.01}
components:
  src: {kind: signal, outputs: {y: {sine: {frequency: 1}}}}
  gain: {kind: fmu, path: Gain.fmu, parameters: {v: [0, 0, 0]}}
connections:
  - src.y -> gain.u
"""

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [0.5, 1, 2, 0.5]
metrics:
  peak: max(gain.y)
  end: final(gain.y)
"""


@pytest.fixture
def fresh_process_state() -> Iterator[None]:
    """Nothing kept before or after the test (the pools belong to the whole process): a
    batch run here makes this process a study's worker, which keeps its isolated children
    too, and a later test's isolated run would be served by one of them."""
    drop_worker_state()
    yield
    drop_worker_state()


def _cases(folder: Path, system: str, study: str) -> list[CaseOutcome]:
    (folder / "system.yaml").write_text(system, encoding="utf-8")
    (folder / "study.yaml").write_text(study, encoding="utf-8")
    plan = plan_study(folder / "study.yaml")[0]
    job = Job.of(plan)
    return run_batch(
        to_json(plan.system), pack_models(plan.system), plan.cases, job, run_study_case
    )


def _with_description_flag(gain: Path, target: Path, flag: str) -> Path:
    """A copy of the Gain FMU whose model description says ``flag`` on its interfaces."""
    with zipfile.ZipFile(gain) as source, zipfile.ZipFile(target, "w") as copy:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                for element in ("<CoSimulation ", "<ModelExchange "):
                    text = text.replace(element, f"{element}{flag} ")
                data = text.encode()
            copy.writestr(item, data)
    return target


def test_the_next_case_takes_the_loaded_fmu_and_gives_the_same_results(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    kept = _cases(tmp_path, SYSTEM, STUDY)
    pool = active_pool()
    assert pool is not None
    assert len(pool) == 1  # one library, handed from case to case
    (loaded,) = pool.idle()
    assert loaded.scratch is not None
    assert loaded.scratch.is_dir()  # unpacked once, kept for the next case
    again = _cases(tmp_path, SYSTEM, STUDY)
    assert pool.idle() == (loaded,)  # the same loaded FMU served the second study's cases
    stop_keeping_libraries()
    assert not loaded.scratch.exists()  # unloaded and removed
    assert active_pool() is None
    plain = [_run_without_pool(tmp_path, case) for case in range(4)]
    for outcomes in (kept, again):
        assert [o.status for o in outcomes] == ["ok"] * 4
        assert [o.metrics for o in outcomes] == plain
    assert kept[0].metrics == kept[3].metrics  # case 4 repeats case 1's k on a used library


def _run_without_pool(folder: Path, index: int) -> dict[str, float | None]:
    """Case ``index`` run as ``fmionnx run`` runs it: its own unpacked copy, nothing kept."""
    from fmionnx.compile.studyir import apply_case

    plan = plan_study(folder / "study.yaml")[0]
    job = Job.of(plan)
    case = plan.cases[index]
    assert active_pool() is None
    return run_study_case(apply_case(plan.system, case), case, job).metrics


def test_an_fmu_that_faulted_is_unloaded_not_kept(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    for name in ("Faulty", "Gain"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    study = (
        "fmionnx: 1\nsystem: system.yaml\nisolate: [none]\n"
        "parameters:\n  bad.mode: [0]\n  bad.failAt: [0.3]\nmetrics:\n  y_end: final(gain.y)\n"
    )
    (outcome,) = _cases(tmp_path, FAULTY_SYSTEM, study)
    assert outcome.status == "fault"
    pool = active_pool()
    assert pool is not None
    # The Gain that ended cleanly stays loaded; the Faulty whose fmi2DoStep failed is unloaded.
    assert [Path(loaded.key[0]).name for loaded in pool.idle()] == ["Gain.fmu"]


def test_an_fmu_that_allows_one_instance_per_process_gets_its_own_copy_every_case(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    _with_description_flag(
        fixture_fmu("Gain"), tmp_path / "Gain.fmu", 'canBeInstantiatedOnlyOncePerProcess="true"'
    )
    outcomes = _cases(tmp_path, SYSTEM, STUDY)
    assert [o.status for o in outcomes] == ["ok"] * 4
    pool = active_pool()
    assert pool is not None
    assert len(pool) == 0


def test_a_forked_child_does_not_use_its_parents_pool(fresh_process_state: None) -> None:
    keep_libraries()
    assert active_pool() is not None
    pid = os.fork()
    if pid == 0:  # the child: a guardian's forked run must load its own
        os._exit(0 if active_pool() is None else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert active_pool() is not None


class _Library:
    """Stands in for fmpy's loaded FMU (a peer of the pool)."""

    def __init__(self) -> None:
        self.freed = False

    def freeLibrary(self) -> None:  # noqa: N802 - fmpy's name
        self.freed = True


def test_the_pool_unloads_the_least_recently_kept_beyond_its_capacity(tmp_path: Path) -> None:
    pool = LibraryPool(capacity=2)
    loaded = [
        LoadedFmu(("a", 0, 0, "r"), None, _Library(), None),
        LoadedFmu(("b", 0, 0, "r"), None, _Library(), None),
        LoadedFmu(("a", 0, 0, "r"), None, _Library(), None),
    ]
    for item in loaded:
        pool.give(item)
    fmus: list[Any] = [item.fmu for item in loaded]
    assert [f.freed for f in fmus] == [True, False, False]
    assert pool.take(("a", 0, 0, "r")) is loaded[2]
    assert pool.take(("a", 0, 0, "r")) is None
    assert pool.take(("b", 0, 0, "r")) is loaded[1]


def test_every_run_of_a_process_shares_one_watchdog_thread(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], fresh_process_state: None
) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    study = STUDY.replace("isolate: [none]", "isolate: [none]\ntimeout: 30")
    outcomes = _cases(tmp_path, SYSTEM, study)
    assert [o.status for o in outcomes] == ["ok"] * 4
    watchdogs = [t for t in threading.enumerate() if t.name == "fmionnx-watchdog"]
    assert len(watchdogs) == 1  # not one started (and waited for) per case
