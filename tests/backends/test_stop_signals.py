"""SIGTERM, SIGHUP and SIGINT stop an in-process run cleanly: the results recorded so far are
written, ``run.json`` says the run was interrupted and by which signal, and the exit code is
the conventional 128 + signal number. A second signal while the results are written does not
cut them off."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import build_fixture_fmu, finish

LONG = """
fmionnx: 1
name: long
run: {{stop: 5000, step: 0.001}}
components:
  integ: {{kind: fmu, path: {integ}, parameters: {{x0: 1.0, u: 0.5}}}}
  gain: {{kind: fmu, path: {gain}, parameters: {{v: [0, 0, 0]}}}}
connections:
  - integ.x -> gain.u
"""


def _started_run(tmp_path: Path) -> subprocess.Popen[str]:
    system = tmp_path / "long.yaml"
    system.write_text(
        LONG.format(integ=build_fixture_fmu("Integrator"), gain=build_fixture_fmu("Gain")),
        encoding="utf-8",
    )
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fmionnx",
            "run",
            str(system),
            "--out",
            str(tmp_path / "out"),
            "--checkpoint-every",
            "0",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stderr is not None
    seen = []
    for line in process.stderr:  # warnings first, then "running long from 0 to 5000 s ..."
        seen.append(line)
        if "running long" in line:
            break
    else:
        process.kill()
        process.communicate()
        pytest.fail("".join(seen))
    run_json = tmp_path / "out" / "run.json"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # a checkpoint after some steps: the loop is running
        time.sleep(0.1)
        if run_json.exists() and json.loads(run_json.read_text(encoding="utf-8"))["steps"] > 0:
            break
    return process


@pytest.mark.parametrize(
    ("signum", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129), (signal.SIGINT, 130)]
)
def test_a_stop_signal_writes_the_results_recorded_so_far(
    tmp_path: Path, signum: signal.Signals, code: int
) -> None:
    process = _started_run(tmp_path)
    process.send_signal(signum)
    _, stderr = finish(process, 120)
    assert process.returncode == code, stderr
    assert f"interrupted by {signum.name}" in stderr
    info = json.loads((tmp_path / "out" / "run.json").read_text(encoding="utf-8"))
    assert info["status"] == "interrupted"
    assert info["interrupted_by"] == signum.name
    with (tmp_path / "out" / "results.csv").open(encoding="utf-8") as stream:
        rows = list(csv.reader(stream))
    # every output is recorded by default, the gain's unconnected ones too
    assert rows[0] == ["time", "integ.x", "gain.y", "gain.w[0]", "gain.w[1]", "gain.w[2]"]
    assert len(rows) - 1 == info["steps"] + 1 > 2  # every completed step, and the start
    last = float(rows[-1][0])
    assert 0 < last < 5000
    assert float(rows[-1][1]) == pytest.approx(1.0 + 0.5 * last, rel=1e-9)


def test_a_second_signal_does_not_cut_off_writing_the_results(tmp_path: Path) -> None:
    process = _started_run(tmp_path)
    process.send_signal(signal.SIGTERM)
    time.sleep(0.05)  # pending signals are delivered lowest number first: let SIGTERM land
    process.send_signal(signal.SIGTERM)
    process.send_signal(signal.SIGHUP)
    _, stderr = finish(process, 120)
    assert process.returncode == 143, stderr
    info = json.loads((tmp_path / "out" / "run.json").read_text(encoding="utf-8"))
    assert info["interrupted_by"] == "SIGTERM"
    assert (tmp_path / "out" / "results.csv").is_file()
