"""A task whose result went with its worker is handed back as a death, never lost.

``as_completed(with_results=True)`` fetched each result itself, and when a task had finished
on a worker that died before the fetch (workers dying together), Dask's fetch raised
``KilledWorker`` inside ``as_completed``, which then never handed the task back: the study
waited for ever. The engine now fetches the result itself (:func:`engine._outcomes`); a
Dask future stands in here for the peer (the whole path runs in
``tests/sweep/test_clean_ends.py``, the fork server killed under a study).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pytest

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.backends.sweep.engine import _died, _outcomes
from tests.sweep.conftest import WriteStudy


def _killed() -> BaseException:
    from distributed.scheduler import KilledWorker

    return KilledWorker("fmionnx-case-0000", None, 0)


@dataclass
class _Future:
    status: str
    value: Any = None

    def result(self) -> Any:
        if isinstance(self.value, BaseException):
            raise self.value
        return self.value

    def exception(self) -> BaseException | None:
        return self.value if isinstance(self.value, BaseException) else None


def test_a_finished_task_gives_its_outcomes() -> None:
    outcomes = [CaseOutcome("case-0000", "ok", "")]
    assert _outcomes(_Future("finished", outcomes)) == outcomes


def test_a_result_gone_with_its_worker_is_a_death() -> None:
    lost = _Future("finished", _killed())
    assert _outcomes(lost) is None
    assert _died(lost) == "the worker running the case died before its result was taken"


def test_a_task_that_did_not_finish_is_a_death() -> None:
    died = _Future("error", _killed())
    assert _outcomes(died) is None
    assert _died(died) == "the worker running the case died (a model crashed its process)"
    assert _outcomes(_Future("cancelled")) is None


def test_a_task_sent_to_a_worker_that_is_gone_does_not_wait_for_ever() -> None:
    """Dask keeps a task whose only named worker is gone unrunnable even when the restriction
    is loose (``allow_other_workers``), whatever workers the cluster has: a study whose task
    went to the worker that had just returned one, as the whole cluster died, waited for
    ever. The local cluster fails such a task after ``no-workers-timeout`` (the engine then
    runs its cases again); were Dask to run it elsewhere instead, it would finish."""
    import time

    from fmionnx.backends.sweep.engine import open_client

    with open_client(workers=1) as client:
        client.wait_for_workers(1)
        (gone,) = client.scheduler_info()["workers"]
        client.cluster.scale(0)  # the whole cluster dies ...
        while client.scheduler_info()["workers"]:
            time.sleep(0.05)
        future = client.submit(int, "1", workers=[gone], allow_other_workers=True, pure=False)
        client.cluster.scale(1)  # ... and a new worker replaces it
        client.wait_for_workers(1)
        deadline = time.monotonic() + 60
        while future.status == "pending" and time.monotonic() < deadline:
            time.sleep(0.1)
        assert future.status in ("error", "finished"), future.status


STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2, 3]
metrics:
  y_end: final(gain.y)
"""


@pytest.mark.parametrize(("losses", "status"), [(2, "ok"), (3, "failed")])
def test_a_case_that_finished_alone_but_lost_its_result_runs_once_more(
    write_study: WriteStudy,
    cluster: str,
    monkeypatch: pytest.MonkeyPatch,
    losses: int,
    status: str,
) -> None:
    """Its result lost, the case runs again alone; lost again alone (it finished: its worker
    died after), it runs once more; only a third loss records it as failed. The losses are
    made on the driver (a real cluster runs the cases): which result a dying worker takes
    with it cannot be chosen."""
    from distributed import Client

    from fmionnx.backends.sweep import engine
    from fmionnx.backends.sweep.case import Job
    from fmionnx.pipeline.study import run_study_case
    from fmionnx.pipeline.sweep import plan_study

    plan, _ = plan_study(write_study(STUDY))
    lost: list[str] = []

    def losing(future: Any) -> list[CaseOutcome] | None:
        outcomes = _outcomes(future)
        if "case-0001" in str(future.key) and outcomes is not None and len(lost) < losses:
            lost.append(str(future.key))
            return None  # as if its worker had died after it finished
        return outcomes

    monkeypatch.setattr(engine, "_outcomes", losing)
    outcomes: list[CaseOutcome] = []
    with Client(cluster, set_as_default=False) as client:
        run = engine.run_study(
            client, plan, plan.cases, Job.of(plan), outcomes.append, run_study_case, batch=1
        )
    by_case = {o.id: o for o in outcomes}
    assert sorted(by_case) == ["case-0000", "case-0001", "case-0002"]
    assert len(outcomes) == 3  # one outcome each
    assert by_case["case-0001"].status == status
    assert [key.endswith("-alone") for key in lost] == [False, True, True][:losses]
    assert run.fallbacks == 1
    if status == "failed":
        assert by_case["case-0001"].message == (
            "the worker running the case died before its result was taken"
        )
