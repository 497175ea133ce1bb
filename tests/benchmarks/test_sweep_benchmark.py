"""benchmarks/sweep.py --quick runs both studies in the three modes to the same metrics.

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
            assert (row["batch"] is None) == (row["mode"] == sweep.LOOP)
    assert len(found["targets"]) == 3
    output = text.getvalue()
    assert "Sweep: cases per second" in output
    assert "overhead vs plain loop" in output
