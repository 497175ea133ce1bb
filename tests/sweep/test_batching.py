"""Several short cases to one Dask task: the same table as one case per task, a failing case
still ends only itself, a batch whose worker dies falls back to one task per case, and an
interrupted study resumes with only the recorded cases counted. One shared local cluster."""

from __future__ import annotations

import csv
import itertools
import json
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.backends.sweep import batching
from fmionnx.backends.sweep.batching import (
    MAX_BATCH,
    MIN_TASK_SECONDS,
    TASK_SECONDS,
    BatchSizer,
    batch_size,
)
from fmionnx.pipeline.sweep import SweepResult, plan_study, run_sweep
from fmionnx.results.study import VOLATILE
from tests.sweep.conftest import WriteStudy
from tests.sweep.test_failures import SYSTEM as FAULTY_SYSTEM

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector
#: (a ResourceWarning raised while collecting, so not attributable to a line of ours).
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

GRID = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2, 3]
  integ.x0: [-1, 0, 0.5, 2]
metrics:
  y_end: final(gain.y)
  y_max: max(gain.y)
"""


def _stable_csv(path: Path) -> list[list[str]]:
    """``cases.csv`` as text cells, without the columns that differ between runs."""
    with path.open(newline="", encoding="utf-8") as stream:
        rows = list(csv.reader(stream))
    keep = [i for i, name in enumerate(rows[0]) if name not in VOLATILE]
    return [[row[i] for i in keep] for row in rows]


# -- the sizing rule ----------------------------------------------------------------------------


def test_each_task_takes_a_share_of_what_is_left_so_the_last_tasks_are_small() -> None:
    assert batch_size(200, 2) == 50  # a quarter: two tasks per thread
    assert batch_size(150, 2) == 38
    assert batch_size(3, 2) == 1  # the last tasks are single cases ...
    assert batch_size(3, 2, per_case=0.001) == 3  # ... unless they are tiny: >= 50 ms of work
    assert batch_size(10**6, 1) == MAX_BATCH
    assert batch_size(20, 2, per_case=30.0) == 5  # long cases too: the budget cuts the task
    sizes, left = [], 200
    while left:
        size = batch_size(left, 2)
        sizes.append(size)
        left -= size
    assert sum(sizes) == 200
    assert sizes == sorted(sizes, reverse=True)  # shrinking: the workers finish together
    assert sizes[0] == 50


def test_once_case_times_are_known_tasks_are_worth_their_cost_and_the_last_ones_even() -> None:
    sizer = BatchSizer(threads=2)
    assert sizer.per_case is None
    assert sizer.budget == TASK_SECONDS
    assert sizer.size(8) == 2  # nothing known: a quarter
    for wall_time in (0.4, 0.001, 0.001, 0.001):  # a first case pays for loading: an outlier
        sizer.observe(wall_time)
    assert sizer.per_case == pytest.approx(0.001)
    least = round(MIN_TASK_SECONDS / 0.001)
    assert sizer.size(1000) == 250  # a quarter is more than the least
    assert sizer.size(400) == max(100, least)
    # Fewer cases left than a least-sized task per thread: one equal share per thread, so
    # that no thread waits for another's last task, and the share holds to the end.
    assert sizer.size(2 * least) == least
    assert sizer.size(least) == least
    assert sizer.size(3) == 3
    fixed = BatchSizer(threads=2, fixed=7)
    assert fixed.size(30) == 7
    assert fixed.size(3) == 3
    assert fixed.budget is None  # a fixed size runs every case it was given


def test_the_first_message_splits_the_cases_evenly_over_the_threads() -> None:
    sizer = BatchSizer(threads=2)
    assert sizer.first_size(200) == 100  # one task per thread carries the whole study
    assert sizer.first_size(7) == 4  # 4 and 3
    assert sizer.first_size(1) == 1
    assert sizer.first_size(10**6) == MAX_BATCH  # then as many as the threads hold
    assert BatchSizer(threads=3).first_size(200) == 67
    assert BatchSizer(threads=2, fixed=7).first_size(200) == 7  # a fixed size is the size


def test_a_task_with_a_budget_stops_after_the_case_that_used_it_up(
    write_study: WriteStudy,
) -> None:
    from fmionnx.backends.sweep.case import Job, run_batch
    from fmionnx.backends.sweep.models import pack_models
    from fmionnx.compile.systemfile import to_json
    from fmionnx.kinds.fmu.libraries import stop_keeping_libraries
    from fmionnx.pipeline.study import run_study_case

    plan = plan_study(write_study(GRID))[0]
    job = Job.of(plan)
    text, models, cases = to_json(plan.system), pack_models(plan.system), plan.cases[:5]
    try:
        assert [o.id for o in run_batch(text, models, cases, job, run_study_case, budget=0.0)] == [
            cases[0].id
        ]
        assert len(run_batch(text, models, cases, job, run_study_case, budget=60.0)) == 5
        assert len(run_batch(text, models, cases, job, run_study_case)) == 5
    finally:
        stop_keeping_libraries()  # what a worker keeps, this test process does not


# -- on a real cluster ----------------------------------------------------------------------------


def test_batches_give_the_same_table_as_one_case_per_task(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    plan = plan_study(write_study(GRID))[0]
    single = run_sweep(plan, tmp_path / "single", scheduler=cluster, batch=1)
    batched = run_sweep(plan, tmp_path / "batched", scheduler=cluster, batch=5)
    adaptive = run_sweep(plan, tmp_path / "adaptive", scheduler=cluster)
    assert single.tasks is not None
    assert batched.tasks is not None
    assert adaptive.tasks is not None
    assert single.tasks.sizes == (1,) * 12
    assert batched.tasks.sizes == (5, 5, 2)
    assert sum(adaptive.tasks.sizes) == 12
    assert adaptive.tasks.sizes == (6, 6)  # 12 cases on 2 threads: one task each
    expected = _stable_csv(tmp_path / "single" / "cases.csv")
    assert len(expected) == 13
    assert _stable_csv(tmp_path / "batched" / "cases.csv") == expected
    assert _stable_csv(tmp_path / "adaptive" / "cases.csv") == expected
    records = sorted(p.name for p in (tmp_path / "batched" / "records").iterdir())
    assert records == [f"case-{i:04d}.json" for i in range(12)]  # one record per case
    table = batched.table
    assert (table["status"] == "ok").all()
    assert (table["wall_time"] > 0).all()  # each case's own time, not its batch's
    assert table["worker"].str.startswith("tcp://").all()


def test_the_records_give_each_workers_timeline(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    """Each record says when its case started on its worker: the cases of a batch, and the
    batches of a worker, follow one another within the study's own time."""
    plan = plan_study(write_study(GRID))[0]
    before = time.time()
    run_sweep(plan, tmp_path / "out", scheduler=cluster, batch=5)
    after = time.time()
    records = [json.loads(p.read_text()) for p in (tmp_path / "out" / "records").iterdir()]
    assert len(records) == 12
    by_worker: dict[str, list[tuple[float, float]]] = {}
    for record in records:
        assert before <= record["started"] <= record["started"] + record["wall_time"] <= after
        by_worker.setdefault(record["worker"], []).append((record["started"], record["wall_time"]))
    for spans in by_worker.values():
        spans.sort()
        for (start, wall), (next_start, _) in itertools.pairwise(spans):
            assert start + wall <= next_start + 1e-3  # one at a time on a one-thread worker


def test_cases_a_task_left_for_lack_of_time_run_in_later_tasks(
    write_study: WriteStudy, tmp_path: Path, cluster: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    plan = plan_study(write_study(GRID))[0]
    single = run_sweep(plan, tmp_path / "single", scheduler=cluster, batch=1)
    monkeypatch.setattr(batching, "TASK_SECONDS", 0.0)  # every task stops after its first case
    cut = run_sweep(plan, tmp_path / "cut", scheduler=cluster)
    assert single.tasks is not None
    assert cut.tasks is not None
    assert cut.tasks.sizes == (1,) * 12  # what each task ran: the rest went to later tasks
    assert cut.tasks.fallbacks == 0
    assert _stable_csv(tmp_path / "cut" / "cases.csv") == _stable_csv(
        tmp_path / "single" / "cases.csv"
    )


def test_a_worker_exempts_what_it_holds_after_its_first_batch_from_the_collector(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    import gc

    from distributed import Client

    plan = plan_study(write_study(GRID))[0]
    run_sweep(plan, tmp_path / "out", scheduler=cluster, batch=6)
    with Client(cluster, set_as_default=False) as client:
        frozen = client.run(gc.get_freeze_count)
    assert len(frozen) == 2
    assert all(count > 1000 for count in frozen.values())  # imports, system, models: frozen


@pytest.fixture
def faulty(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    for name in ("Faulty", "Gain"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    (tmp_path / "system.yaml").write_text(FAULTY_SYSTEM, encoding="utf-8")
    return tmp_path


def _faulty_sweep(faulty: Path, cluster: str, settings: str, *, batch: int) -> SweepResult:
    """The study ``settings`` (options and parameters) over the faulty system, measuring
    ``gain.y`` at the end, run on ``cluster`` in batches of ``batch``."""
    study = faulty / "study.yaml"
    study.write_text(
        f"fmionnx: 1\nsystem: system.yaml\n{settings}metrics:\n  y_end: final(gain.y)\n",
        encoding="utf-8",
    )
    return run_sweep(plan_study(study)[0], faulty / "out", scheduler=cluster, batch=batch)


def test_a_crash_or_hang_inside_a_batch_ends_only_its_own_case(faulty: Path, cluster: str) -> None:
    result = _faulty_sweep(
        faulty,
        cluster,
        "timeout: 60\nstep_timeout: 4\n"
        "parameters:\n  bad.mode: [3, 6, 0]\n  bad.failAt: [0.3, 5]\n",
        batch=6,
    )
    assert result.tasks is not None
    assert result.tasks.sizes == (6,)
    assert result.tasks.fallbacks == 0
    rows = {(r["bad.mode"], r["bad.failAt"]): r for r in result.table.to_dict("records")}
    for mode in (3, 6, 0):  # failing after the stop time: the batch-mates ran to the end
        assert rows[(mode, 5.0)]["status"] == "ok"
        assert rows[(mode, 5.0)]["y_end"] == 4.0
    assert rows[(3, 0.3)]["status"] == "fault"  # segfault of the isolated model
    assert rows[(6, 0.3)]["status"] == "fault"  # hang, killed at the step timeout
    assert "4 s" in rows[(6, 0.3)]["message"]
    assert rows[(0, 0.3)]["status"] == "fault"


def test_a_batch_whose_worker_dies_runs_its_cases_again_one_task_each(
    faulty: Path, cluster: str
) -> None:
    result = _faulty_sweep(
        faulty,
        cluster,
        "isolate: [none]\nparameters:\n  bad.failAt: [5, 0.3]\n  gain.k: [1, 2]\n  bad.mode: [3]\n",
        batch=4,
    )
    assert result.tasks is not None
    assert result.tasks.sizes == (4, 1, 1, 1, 1)  # the batch, then each of its cases alone
    assert result.tasks.fallbacks == 4
    rows = {(r["bad.failAt"], r["gain.k"]): r for r in result.table.to_dict("records")}
    for k in (1.0, 2.0):
        assert rows[(5.0, k)]["status"] == "ok"
        assert rows[(5.0, k)]["y_end"] == 2.0 * k
        assert rows[(0.3, k)]["status"] == "failed"  # the segfault kills its worker
        assert "worker" in rows[(0.3, k)]["message"]


class _InterruptedError(Exception):
    """Stands for Ctrl-C on the driver while a batch's outcomes are being recorded."""


def test_an_interruption_inside_a_batch_keeps_only_the_recorded_cases(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    plan = plan_study(write_study(GRID))[0]
    full = run_sweep(plan, tmp_path / "full", scheduler=cluster, batch=1).table
    out = tmp_path / "out"

    def interrupt(done: int, failed: int, total: int) -> None:
        if done == 4:  # the first case of the second batch of three is recorded
            raise _InterruptedError

    with pytest.raises(_InterruptedError):
        run_sweep(plan, out, scheduler=cluster, batch=3, progress=interrupt)
    recorded = sorted(p.stem for p in (out / "records").iterdir())
    assert len(recorded) == 4  # the second batch's other cases ran, but count as not finished
    assert not (out / "cases.csv").exists()
    kept = {name: (out / "records" / f"{name}.json").read_text() for name in recorded}
    resumed = run_sweep(plan, out, scheduler=cluster, batch=3, resume=True)
    assert resumed.resumed == 4
    assert resumed.tasks is not None
    assert sum(resumed.tasks.sizes) == 8
    for name, text in kept.items():
        assert (out / "records" / f"{name}.json").read_text() == text
    assert _stable_csv(out / "cases.csv") == _stable_csv(tmp_path / "full" / "cases.csv")
    assert len(full) == 12


def test_the_command_takes_a_batch_size(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    study = write_study(GRID)
    args = ["sweep", str(study), "--out", str(tmp_path / "out"), "--scheduler", cluster]
    result = CliRunner().invoke(app, [*args, "--batch", "4", "--quiet"])
    assert result.exit_code == 0, result.output
    assert _stable_csv(tmp_path / "out" / "cases.csv")[0][:3] == ["case", "gain.k", "integ.x0"]
    refused = CliRunner().invoke(app, [*args, "--batch", "0"], env={"COLUMNS": "100"})
    assert refused.exit_code == 2
    assert "--batch" in refused.output
