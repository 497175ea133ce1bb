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

from fmionnx.backends.sweep.case import CaseOutcome
from fmionnx.backends.sweep.engine import _died, _outcomes


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


def test_a_result_dask_is_computing_again_is_a_death_said_at_once() -> None:
    """Lost with its worker, a result leaves the future ``lost`` while Dask computes it again;
    asking it for its exception waited for that and gave ``None`` ("NoneType: None")."""

    @dataclass
    class _Waiting(_Future):
        def exception(self) -> BaseException | None:
            raise AssertionError("asked a future that has not ended for its exception")

    lost = _Waiting("lost")
    assert _outcomes(lost) is None
    assert _died(lost) == "the worker running the case died before its result was taken"
    assert _died(_Waiting("cancelled")) == (
        "the worker running the case is gone (its task is cancelled)"
    )


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
