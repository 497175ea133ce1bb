"""How the engine hands tasks to a real local cluster's workers: the first tasks in one message,
one per thread, cut equal; every later task to the worker that returned one; workers that join
get tasks; the system and models inside the tasks or as tasks of their own, with the same
outcomes.

The scheduler is watched by a plugin added to it directly (a local cluster's scheduler lives in
this process): it records, for every task of the study, the workers it was restricted to and
the worker that ran it.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from distributed.diagnostics.plugin import SchedulerPlugin

from fmionnx.backends.sweep import engine
from fmionnx.backends.sweep.case import CaseOutcome, Job
from fmionnx.pipeline.study import run_study_case
from fmionnx.pipeline.sweep import plan_study
from tests.sweep.conftest import WriteStudy

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: {{range: {{start: 0.5, stop: 2, num: {num}}}}}
metrics:
  y_end: final(gain.y)
"""


class _Where(SchedulerPlugin):
    """Each study task's worker restrictions and the worker it was first assigned to."""

    def __init__(self, scheduler: Any) -> None:
        self.restricted: dict[str, set[str]] = {}
        self.ran_on: dict[str, str] = {}
        self.order: list[str] = []
        self._scheduler = scheduler

    def transition(self, key: Any, start: str, finish: str, *args: Any, **kwargs: Any) -> None:
        name = str(key)
        if "-case-" not in name:
            return
        state = self._scheduler.tasks.get(key)
        if finish == "processing" and state is not None and name not in self.restricted:
            self.order.append(name)
            self.restricted[name] = set(state.worker_restrictions or ())
            self.ran_on[name] = state.processing_on.address


@pytest.fixture
def watched() -> Iterator[tuple[Any, _Where]]:
    """A client of a new 2-worker local cluster whose scheduler is watched."""
    with engine.open_client(workers=2) as client:
        client.wait_for_workers(2)
        where = _Where(client.cluster.scheduler)
        client.cluster.scheduler.add_plugin(where)
        yield client, where


def _run(client: Any, study: Path, **options: Any) -> tuple[list[CaseOutcome], engine.StudyRun]:
    plan, _ = plan_study(study)
    outcomes: list[CaseOutcome] = []
    run = engine.run_study(
        client, plan, plan.cases, Job.of(plan), outcomes.append, run_study_case, **options
    )
    return outcomes, run


def test_tasks_after_the_first_go_to_the_worker_that_returned_one(
    write_study: WriteStudy, watched: tuple[Any, _Where]
) -> None:
    client, where = watched
    outcomes, run = _run(client, write_study(STUDY.format(num=16)), batch=1)

    assert sorted(o.status for o in outcomes) == ["ok"] * 16
    first = engine.DEPTH * 2  # two tasks in hand per worker thread, two workers
    assert run.sizes == (1,) * 16
    assert len(where.order) == 16
    for key in where.order[:first]:  # one message; the scheduler picks their workers
        assert where.restricted[key] == set(), key
    for key in where.order[first:]:
        assert len(where.restricted[key]) == 1, key  # sent to one worker, which ran it
        assert where.restricted[key] == {where.ran_on[key]}, key
    assert len(set(where.ran_on.values())) == 2  # both workers ran cases


@pytest.mark.slow  # which worker takes which task needs the machine to itself: `make soak`
def test_the_first_message_is_one_equal_task_per_thread(
    write_study: WriteStudy, watched: tuple[Any, _Where]
) -> None:
    """The scheduler assigns tasks sent together at once, and picks which worker runs which:
    the first message is one task per thread, cut equal (guided sizes would shrink: 6, 5, 4,
    3 for 24 cases on 2 threads; two tasks per thread, 6 each, cost twice the tasks)."""
    client, where = watched
    outcomes, run = _run(client, write_study(STUDY.format(num=24)))

    assert sorted(o.status for o in outcomes) == ["ok"] * 24
    assert run.sizes == (12, 12)
    assert all(not workers for workers in where.restricted.values())
    assert len(set(where.ran_on.values())) == 2  # one task for each worker


def test_a_worker_that_joins_during_a_study_gets_tasks(
    write_study: WriteStudy, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(engine, "REFRESH_SECONDS", 0.0)  # ask the scheduler at every refill
    study = write_study(STUDY.format(num=12))
    plan, _ = plan_study(study)
    outcomes: list[CaseOutcome] = []
    with engine.open_client(workers=1) as client:
        client.wait_for_workers(1)
        first = set(client.nthreads())

        def on_done(outcome: CaseOutcome) -> None:
            if not outcomes:  # the first case is back: a second worker joins, and is up
                client.cluster.scale(2)
                client.wait_for_workers(2)
            outcomes.append(outcome)

        engine.run_study(client, plan, plan.cases, Job.of(plan), on_done, run_study_case, batch=1)
        joined = set(client.nthreads()) - first

    assert sorted(o.status for o in outcomes) == ["ok"] * 12
    assert len(joined) == 1
    assert any(o.worker in joined for o in outcomes)


@pytest.mark.parametrize("inline_bytes", [engine.INLINE_BYTES, 0], ids=["inside", "as-tasks"])
def test_system_and_models_reach_the_workers_either_way(
    write_study: WriteStudy,
    watched: tuple[Any, _Where],
    monkeypatch: pytest.MonkeyPatch,
    inline_bytes: int,
) -> None:
    """Small ones travel inside every task, larger ones as tasks of their own: same outcomes."""
    monkeypatch.setattr(engine, "INLINE_BYTES", inline_bytes)
    client, _ = watched
    outcomes, _ = _run(client, write_study(STUDY.format(num=6)), batch=2)

    by_id = {o.id: o for o in outcomes}
    assert [by_id[f"case-{i:04d}"].status for i in range(6)] == ["ok"] * 6
    gains = [0.5 + 0.3 * i for i in range(6)]
    assert [by_id[f"case-{i:04d}"].metrics["y_end"] for i in range(6)] == pytest.approx(gains)
    plan, _ = plan_study(write_study(STUDY.format(num=6)))
    shared = engine._shared(client, plan, Job.of(plan), None, "fmionnx-test")
    inside = all(isinstance(value, (str, dict, Job)) for value in shared)
    assert inside == (inline_bytes > 0)
