"""``--isolate guardian``: the whole run in one guarded child process (issue #14).

The same misbehaving Faulty FMU as the isolation tests: whatever it does to the run's
process, ``fmionnx run`` exits 1 with a fault naming the component and the time, and writes
every completed step; a completed run is byte-identical to the unguarded one; stop signals
and the step timeout behave as in-process; no temporary folder is left behind.
"""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from fmionnx.results.csvfile import read_csv
from tests.backends.test_isolation import (
    ABORT,
    EXIT,
    HANG,
    SEGFAULT,
    SYSTEM,
    _assert_results_up_to,
    _cli,
    _finish,
    _system,
)
from tests.backends.test_stop_signals import LONG
from tests.conftest import build_fixture_fmu


@pytest.mark.parametrize(
    ("mode", "how"),
    [
        (SEGFAULT, "the model crashed with SIGSEGV during its step"),
        (ABORT, "the model crashed with SIGABRT during its step"),
        (EXIT, "the model ended the run's process with exit status 3 during its step"),
    ],
)
def test_a_model_that_kills_the_guarded_process_is_a_fault_with_every_completed_step(
    fixture_fmu, write_system, tmp_path: Path, mode: int, how: str
) -> None:
    system = _system(fixture_fmu, write_system, mode)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--isolate", "guardian"]
    code, output = _finish(_cli(args, tmp))
    assert code == 1, output
    # the two FMUs are stepped by one native call: the fault names both
    assert f"component `bad+gain` at t=0.3 s: {how}" in output, output
    assert output.rstrip().endswith(f"Results: {out}")
    table = read_csv(out / "results.csv")  # every completed step: 0 .. 0.3
    assert len(table["time"]) == 31
    assert table["time"][-1] == pytest.approx(0.3)
    assert np.isfinite(table["bad.y"]).all()
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "fault"
    assert info["error"]["component"] == "bad+gain"
    assert list(tmp.iterdir()) == []  # the child's extraction folders are gone too


def test_a_model_stepped_alone_is_named_alone(fixture_fmu, write_system, tmp_path: Path) -> None:
    system = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=f"{fixture_fmu('Gain')}, interface: me",
            mode=SEGFAULT, stop=1.0, step=0.01, fail_at=0.5,
        )
    )  # fmt: skip
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    code, output = _finish(_cli(["run", str(system), "-q", "--out", str(out), "--isolate", "guardian"], tmp))  # fmt: skip
    assert code == 1, output
    assert "component `bad` at t=0.5 s: the model crashed with SIGSEGV" in output, output
    assert len(_assert_results_up_to(out, 0.5)["time"]) == 51


def test_a_guarded_run_writes_the_same_bytes_as_an_unguarded_one(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    system = _system(fixture_fmu, write_system, 0, stop=3.0, fail_at=10.0)  # never fails
    files = {}
    for isolate in ("guardian", "none", "fmus"):
        out = tmp_path / isolate
        code, output = _finish(
            _cli(["run", str(system), "-q", "--out", str(out), "--isolate", isolate], tmp_path / "tmp")
        )  # fmt: skip
        assert code == 0, output
        files[isolate] = (out / "results.csv").read_bytes()
        assert json.loads((out / "run.json").read_text())["status"] == "completed"
    assert files["guardian"] == files["none"] == files["fmus"]
    assert files["guardian"].count(b"\n") == 302


def test_sigterm_stops_a_guarded_run_with_its_results(tmp_path: Path) -> None:
    system = tmp_path / "long.yaml"
    system.write_text(
        LONG.format(integ=build_fixture_fmu("Integrator"), gain=build_fixture_fmu("Gain")),
        encoding="utf-8",
    )
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "-q", "--out", str(out), "--isolate", "guardian"]
    process = _cli([*args, "--checkpoint-every", "0"], tmp)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.1)  # a checkpoint, written by the guarded process: the loop is running
        if (out / "run.json").exists() and json.loads((out / "run.json").read_text())["steps"]:
            break
    process.send_signal(signal.SIGTERM)
    code, output = _finish(process, timeout=120)
    assert code == 143, output
    assert "interrupted by SIGTERM" in output
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted"
    assert info["interrupted_by"] == "SIGTERM"
    table = read_csv(out / "results.csv")
    assert len(table["time"]) == info["steps"] + 1 > 2  # every completed step, and the start
    assert list(tmp.iterdir()) == []


def test_a_hang_is_abandoned_by_the_watchdog_in_the_guarded_process(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    system = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=f"{fixture_fmu('Gain')}, interface: me", mode=HANG,
            stop=1.0, step=0.01, fail_at=0.3,
        )
    )  # fmt: skip
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--isolate", "guardian", "--step-timeout", "1"]
    code, output = _finish(_cli(args, tmp))
    assert code == 1, output
    assert "at t=0.3 s: a step did not return within 1 s" in output
    assert output.rstrip().endswith(f"Results: {out}")
    assert output.count("Results:") == 1  # written once, by the guarded process
    _assert_results_up_to(out, 0.3)
    assert list(tmp.iterdir()) == []


def test_guardian_does_not_combine_with_record(fixture_fmu, write_system, tmp_path: Path) -> None:
    system = _system(fixture_fmu, write_system, 0, fail_at=10.0)
    args = ["run", str(system), "--isolate", "guardian", "--record", str(tmp_path / "r.mcap")]
    code, output = _finish(_cli(args, tmp_path / "tmp"))
    assert code == 2, output
    assert "--isolate guardian does not combine with --record" in output
    assert not (tmp_path / "r.mcap").exists()


def test_ctrl_c_stops_a_guarded_run_stuck_in_a_model(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    system = _system(fixture_fmu, write_system, HANG)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--isolate", "guardian"]
    process = _cli([*args, "--checkpoint-every", "0"], tmp)
    deadline = time.monotonic() + 60
    while not (out / "results.csv").exists() and time.monotonic() < deadline:
        time.sleep(0.2)  # the first checkpoint: the run is under way
        if process.poll() is not None:
            break
    time.sleep(1.0)  # by now the model hangs in its step at t = 0.3 s
    process.send_signal(signal.SIGINT)
    code, output = _finish(process)
    assert code == 130, output  # the stuck process was killed after the grace period
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted"
    assert info["interrupted_by"] == "SIGINT"
    assert len(read_csv(out / "results.csv")["time"]) == 31  # 0 .. 0.3: every completed step
    assert list(tmp.iterdir()) == []


def test_rows_recorded_after_the_shared_tracks_grew_are_kept(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    # 80 000 steps: beyond the 65 536 rows a track reserves first, so the rows moved once
    system = _system(fixture_fmu, write_system, SEGFAULT, stop=1000.0, fail_at=800.0)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "-q", "--out", str(out), "--isolate", "guardian"]
    code, output = _finish(_cli(args, tmp))
    assert code == 1, output
    assert "at t=800 s: the model crashed with SIGSEGV" in output
    table = read_csv(out / "results.csv")
    assert len(table["time"]) == 80_001
    assert table["time"][-1] == 800.0
    assert list(tmp.iterdir()) == []
