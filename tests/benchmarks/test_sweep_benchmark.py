"""benchmarks/sweep.py --quick runs both studies in the four modes to the same metrics.

Timings are never asserted (the machine is shared); what is checked is that every mode ran
every case, none failed, every mode gave the loop's metrics, and the tables were printed.
The quick run takes about 17 s on 2 shared cores.
"""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from benchmarks import sweep
from tests.conftest import built_model

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


def test_quick_sweep_benchmark_runs_every_mode_to_the_loops_metrics() -> None:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    text = io.StringIO()
    found = sweep.main(["--quick"], Console(file=text, width=200))

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
    assert "Sweep: cases per second" in output
    assert "overhead vs plain loop" in output
