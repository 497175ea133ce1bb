"""``fmionnx sweep --rrd``: each case's Rerun recording, made on its worker, kept beside its
results (``cases/<id>/run.rrd``) and read back through Rerun's own reader."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.pipeline.sweep import plan_study, run_sweep
from tests.sweep.conftest import WriteStudy

rerun_chunk = pytest.importorskip("rerun.chunk")

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2]
metrics:
  y_end: final(gain.y)
"""


def test_each_case_keeps_its_recording(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    out = tmp_path / "out"
    result = run_sweep(plan_study(write_study(STUDY))[0], out, scheduler=cluster, rrd=True)
    assert list(result.table["status"]) == ["ok", "ok"]
    for case in result.table["case"]:
        rrd = out / "cases" / str(case) / "run.rrd"
        rows: dict[str, int] = {}
        for chunk in rerun_chunk.RrdReader(rrd).store().stream():
            path = str(chunk.entity_path)
            rows[path] = rows.get(path, 0) + chunk.num_rows
        assert rows["/gain/y"] == 101  # 100 base steps of 0.01 s, every one a row
        assert rows["/graph"] == 1
        assert "/checks/small" in rows


def test_without_rrd_no_recording_is_kept(
    write_study: WriteStudy, tmp_path: Path, cluster: str
) -> None:
    out = tmp_path / "out"
    run_sweep(plan_study(write_study(STUDY))[0], out, scheduler=cluster)
    assert not list(out.rglob("*.rrd"))
