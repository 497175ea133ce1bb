"""Several short cases to one Dask task: the same table as one case per task, a failing case
still ends only itself, a batch whose worker dies falls back to one task per case, and an
interrupted study resumes with only the recorded cases counted. One shared local cluster."""

from __future__ import annotations

import csv
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.backends.sweep.batching import (
    MAX_BATCH,
    TASKS_LEFT_PER_THREAD,
    BatchSizer,
    batch_size,
)
from fmionnx.results.study import VOLATILE
from fmionnx.results.sweep import plan_study, run_sweep
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


def test_short_cases_fill_half_a_second_and_the_rest_keeps_every_worker_busy() -> None:
    assert batch_size(0.005, 10_000, 2) == 100  # 0.5 s of 5 ms cases
    assert batch_size(0.005, 200, 2) == 25  # 200 left: at least 4 tasks per thread
    assert batch_size(0.005, 8, 2) == 1  # the last tasks are single cases
    assert batch_size(3.0, 10_000, 2) == 1  # cases of seconds: one per task, as before
    assert batch_size(0.0, 10**6, 1) == MAX_BATCH
    left = 200
    while left:  # the cases still unfinished always make >= 4 tasks per thread, or are singles
        size = batch_size(0.001, left, 2)
        assert size == 1 or left / size >= TASKS_LEFT_PER_THREAD * 2
        left -= size


def test_the_sizer_probes_first_and_leaves_each_workers_first_case_out() -> None:
    sizer = BatchSizer(threads=2)
    assert not sizer.ready
    assert sizer.size(1000) == 1
    sizer.observe("tcp://a", 2.0)  # the first case on a worker: models received, not typical
    sizer.observe("tcp://b", 2.0)
    assert not sizer.ready
    sizer.observe("tcp://a", 0.01)
    sizer.observe("tcp://b", 0.03)
    assert sizer.per_case == pytest.approx(0.02)
    assert sizer.size(1000) == 25
    assert BatchSizer(threads=2, fixed=7).size(3) == 7  # fixed: as asked (the engine clips it)


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


@pytest.fixture
def faulty(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    for name in ("Faulty", "Gain"):
        shutil.copy(fixture_fmu(name), tmp_path / f"{name}.fmu")
    (tmp_path / "system.yaml").write_text(FAULTY_SYSTEM, encoding="utf-8")
    return tmp_path


def test_a_crash_or_hang_inside_a_batch_ends_only_its_own_case(faulty: Path, cluster: str) -> None:
    (faulty / "study.yaml").write_text(
        "fmionnx: 1\nsystem: system.yaml\ntimeout: 60\nstep_timeout: 4\n"
        "parameters:\n  bad.mode: [3, 6, 0]\n  bad.failAt: [0.3, 5]\n"
        "metrics:\n  y_end: final(gain.y)\n"
    )
    result = run_sweep(plan_study(faulty / "study.yaml")[0], faulty / "out", scheduler=cluster,
                       batch=6)  # fmt: skip
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
    (faulty / "study.yaml").write_text(
        "fmionnx: 1\nsystem: system.yaml\nisolate: [none]\n"
        "parameters:\n  bad.failAt: [5, 0.3]\n  gain.k: [1, 2]\n  bad.mode: [3]\n"
        "metrics:\n  y_end: final(gain.y)\n"
    )
    result = run_sweep(plan_study(faulty / "study.yaml")[0], faulty / "out", scheduler=cluster,
                       batch=4)  # fmt: skip
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
