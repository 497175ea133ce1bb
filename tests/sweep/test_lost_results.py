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


def test_a_task_that_did_not_finish_is_a_death() -> None:
    died = _Future("error", _killed())
    assert _outcomes(died) is None
    assert _died(died) == "the worker running the case died (a model crashed its process)"
    assert _outcomes(_Future("cancelled")) is None
