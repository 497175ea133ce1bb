"""One thread budget per worker, counted: a worker of the local cluster that runs reference
scenario cases adds one render thread (and Mesa's cache thread and fmionnx's watchdog) to
Dask's own, whatever the machine's cores; its isolated children run on one thread each; and
what it loads once -- the scene with its GL context, the ONNX session, the isolated models'
processes -- serves its next cases with the results of runs made from scratch.

Counted by thread name in ``/proc``: on a 2-core machine an unbudgeted worker already shows it
(llvmpipe starts a thread per core, onnxruntime's pool one per core but the caller's, OpenBLAS
the same), and on a larger machine each grows with the cores.
"""

from __future__ import annotations

import os
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from fmionnx.backends.sweep.case import CaseOutcome, Job
from fmionnx.backends.sweep.engine import open_client, run_study
from fmionnx.compile.studyir import apply_case
from fmionnx.pipeline.study import run_study_case
from fmionnx.pipeline.sweep import plan_study
from tests.conftest import REPO, built_model
from tests.processes import child_pids

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

STUDY = """\
fmionnx: 1
system: {system}
parameters:
  tracker.turnRate: [0.8, 1.0, 0.8]
  run.stop: [0.4]
metrics:
  x_end: final(odometry.posX)
  y_end: final(odometry.posY)
  theta_end: final(odometry.theta)
"""

#: Threads a worker's first case may add to it, none of them per core: Dask's task thread
#: (started with the first task), fmionnx's step watchdog, the one onnxruntime starts when
#: imported, and the renderer's three (Mesa's rasteriser thread ``llvmpipe-0``, its
#: shader-cache thread and an EGL helper). Later cases add none (nothing leaks, and the GL
#: context is kept).
CASE_THREADS = 6


def _threads(pid: int) -> Counter[str]:
    names: Counter[str] = Counter()
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            names[(task / "comm").read_text().strip()] += 1
        except OSError:  # ended meanwhile
            continue
    return names


def _descendants(pid: int) -> list[int]:
    found = []
    for child in child_pids(pid):
        found += [child, *_descendants(child)]
    return found


def inventory() -> dict[str, Any]:
    """On the worker: its threads by name, its descendants' thread counts, what it keeps."""
    import threading

    from fmionnx.kinds.mujoco.runner import SCENES
    from fmionnx.kinds.onnx.runner import SESSIONS
    from fmionnx.runtime.isolated import proxy

    pool = proxy._children.get()
    return {
        "python_threads": sorted(t.name for t in threading.enumerate()),
        "threads": dict(_threads(os.getpid())),
        "descendants": {pid: sum(_threads(pid).values()) for pid in _descendants(os.getpid())},
        "scenes": len(SCENES),
        "sessions": len(SESSIONS),
        "children": sorted(c.process.pid for c in pool._idle) if pool is not None else [],
    }


@pytest.fixture(scope="module")
def study() -> Path:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    folder = Path(tempfile.mkdtemp(prefix="fmionnx-thread-budget-"))
    path = folder / "study.yaml"
    system = (REPO / "systems" / "sign_follower.yaml").as_posix()
    path.write_text(STUDY.format(system=system), encoding="utf-8")
    return path


@pytest.mark.parametrize("start", ["spawned", "forked"])
def test_a_worker_runs_its_cases_within_one_thread_budget_and_keeps_its_models(
    study: Path, start: str, request: pytest.FixtureRequest
) -> None:
    """Spawned by Dask's nanny (a program calling ``fmionnx.sweep``) or forked from the
    command's fork server (``fmionnx sweep``, :mod:`fmionnx.backends.sweep.workerfork`)."""
    import sys

    if start == "forked":
        request.getfixturevalue("forked")

    import cloudpickle

    # The workers cannot import this test module: its functions travel by value.
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    plan = plan_study(study)[0]
    job = Job.of(plan)
    outcomes: list[CaseOutcome] = []
    seen: list[dict[str, Any]] = []
    with open_client(workers=1) as client:
        client.wait_for_workers(1)
        (before,) = client.run(inventory).values()
        for case in plan.cases:  # one at a time: each case's own task
            run_study(client, plan, [case], job, outcomes.append, run_study_case, batch=1)
            (after,) = client.run(inventory).values()
            seen.append(after)
    for after in seen:
        added = sum(after["threads"].values()) - sum(before["threads"].values())
        assert added <= CASE_THREADS, (before, after)
        assert after["threads"] == seen[0]["threads"]  # nothing more from later cases
        assert sum(n for name, n in after["threads"].items() if "llvmpipe" in name) == 1
        assert set(after["descendants"].values()) == {1}  # zygote and children: 1 thread each
        assert after["scenes"] == 1  # the scene and its GL context, kept for the next case
        assert after["sessions"] == 1  # the detector's session, kept for the next case
        assert len(after["children"]) == 2  # odometry's and tracker's processes ...
        assert after["children"] == seen[0]["children"]  # ... the same ones every case
    assert [o.status for o in outcomes] == ["ok"] * 3
    kept = [o.metrics for o in outcomes]
    assert kept[0] == kept[2]  # case 3 repeats case 1's settings on everything kept
    fresh = [run_study_case(apply_case(plan.system, c), c, job).metrics for c in plan.cases]
    assert kept == fresh  # a run made from scratch in this process, nothing kept
