"""benchmarks/sweep.py --quick: the scaling tables (``fmionnx sweep --workers W`` for 1 and 2
workers) and, with ``--modes``, both studies in the four modes to the same metrics.

Timings are never asserted (the machine is shared); what is checked is that every mode and
worker count ran every case, none failed, every mode gave the loop's metrics, the targets this
machine cannot measure say so, and the tables were printed. The quick run takes about 90 s on
2 shared cores.
"""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from benchmarks import sweep
from tests.conftest import built_model

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = [
    pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning"),
    pytest.mark.slow,
]  # slow: a benchmark's quick run; `make soak` runs it


def test_quick_sweep_benchmark_runs_every_mode_to_the_loops_metrics() -> None:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    text = io.StringIO()
    found = sweep.main(["--quick", "--modes"], Console(file=text, width=200))

    scaling = found["scaling"]
    assert scaling["failed"] == 0
    assert scaling["counts"] == [1, 2]
    by_study: dict[str, list[int]] = {}
    for row in scaling["rows"]:
        by_study.setdefault(row["study"], []).append(row["workers"])
        assert row["seconds"] > 0
        assert 0.0 <= row["busy"] <= 1.0  # the cases' wall over the workers' wall
        assert row["outside"] == pytest.approx(1 - row["busy"])
        assert row["before_s"] > 0  # the command's start and compile come first
        assert row["after_s"] > 0  # the table comes last
        assert row["idle_s"] >= -0.01  # a worker runs one case at a time
    assert by_study == {
        "reference": [1, 2],
        "reference, isolate: [none]": [2],
        "reference, workers spawned": [2],
        "small FMU system": [1, 2],
    }
    reference_rows = [row for row in scaling["rows"] if row["study"] == "reference"]
    assert reference_rows[0]["speedup"] == 1
    assert reference_rows[0]["per_case_vs_1"] == 1
    scaling_targets = {row["target"]: row for row in scaling["targets"]}
    measured = [row for name, row in scaling_targets.items() if "not measured" not in name]
    assert len(measured) == 2
    assert all(row["value"] is not None for row in measured)
    unmeasured = [row for name, row in scaling_targets.items() if "not measured" in name]
    assert len(unmeasured) == 2
    assert all(row["value"] is None for row in unmeasured)

    for study, cases in (("small", 10 * 2), ("scenario", 2)):  # the small study twice whole
        rows = found[study]
        assert [row["mode"] for row in rows] == list(sweep.MODES)
        for row in rows:
            assert row["cases"] == cases
            assert row["failed"] == 0
            assert row["same_metrics"], f"{study}: {row['mode']} differs from the loop"
            assert row["seconds"] > 0
            clustered = row["mode"] not in (sweep.LOOP, sweep.PROCESSES)
            assert (row["batch"] is not None) == clustered
            # The study's latency: measured on each cluster, for the small study only.
            assert (row["latency_ms"] is not None) == (clustered and study == "small")
            assert (row["vs_1_process"] is not None) == (row["mode"] == sweep.PROCESSES)
    targets = [row["target"] for row in found["targets"]]
    assert len(targets) == 6
    assert sum("2 plain processes vs 1" in target for target in targets) == 2
    assert sum("plus the latency" in target for target in targets) == 1
    assert all(row["value"] is not None for row in found["targets"])
    output = text.getvalue()
    assert "Sweep scaling" in output
    assert "not measured: this machine has 2 usable cores" in output
    assert "Sweep: cases per second" in output
    assert "overhead vs plain loop" in output
