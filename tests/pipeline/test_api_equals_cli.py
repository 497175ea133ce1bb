"""The Python API runs what the CLI runs: the same request, the same pipeline, the same files.

``fmionnx.run(path, **options)`` takes every ``fmionnx run`` option under its flag's name in
snake_case. For the same request its ``results.csv`` is byte for byte the CLI's, and the
signals it returns are that file's columns, exactly: in-process, and as ROS 2 nodes in
lockstep over DDS and over Zenoh. It applies the CLI's defaults: FMUs isolated, so a crashing
FMU is a fault with the results so far, not the end of the calling process.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.pipeline.errors import RequestError
from fmionnx.results.csvfile import read_csv
from fmionnx.runtime.result import RunStatus
from tests.backends.test_isolation import SEGFAULT, SYSTEM
from tests.conftest import build_fixture_fmu
from tests.ros2.test_run import fmionnx as fmionnx_command
from tests.ros2.test_run import loop_system

#: The API in a fresh interpreter: ROS 2 runs start node processes and DDS participants of
#: their own, which the test process should not keep.
API_SCRIPT = """
import json, sys
from pathlib import Path
import fmionnx

system, out, options = sys.argv[1], Path(sys.argv[2]), json.loads(sys.argv[3])
outcome = fmionnx.run(system, out=out, **options)
signals = {name: [float(v).hex() for v in values] for name, values in outcome.result.signals.items()}
time = [float(v).hex() for v in outcome.result.time]
(out / "api.json").write_text(json.dumps({"time": time, "signals": signals,
                                          "status": outcome.status.value,
                                          "exit": outcome.exit_status}))
"""


def _cli(system: Path, out: Path, *flags: str) -> None:
    done = subprocess.run(
        fmionnx_command("run", system, "-q", "--out", out, *flags),
        capture_output=True, text=True, timeout=180, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr


def _api(system: Path, out: Path, **options: object) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", API_SCRIPT, str(system), str(out), json.dumps(options)],
        capture_output=True, text=True, timeout=180, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    result: dict[str, object] = json.loads((out / "api.json").read_text(encoding="utf-8"))
    return result


def _same_as_csv(api: dict[str, object], csv: Path) -> None:
    """The API's signals are the CSV's columns, value for value (exact float64 bits)."""
    table = read_csv(csv)
    signals = api["signals"]
    assert isinstance(signals, dict)
    assert sorted(signals) == sorted(name for name in table if name != "time")
    exact = {name: [float.fromhex(v) for v in values] for name, values in signals.items()}
    assert np.array_equal(table["time"], [float.fromhex(v) for v in api["time"]])  # type: ignore[union-attr]
    for name, values in exact.items():
        assert np.array_equal(table[name], values, equal_nan=True), name


def test_inprocess_api_run_writes_the_clis_results_byte_for_byte(tmp_path: Path) -> None:
    system = loop_system(tmp_path, 1.0)
    cli, api = tmp_path / "cli", tmp_path / "api"
    _cli(system, cli)
    outcome = fmionnx.run(system, out=api)
    assert outcome.status is RunStatus.COMPLETED
    assert outcome.exit_status == 0
    assert (api / "results.csv").read_bytes() == (cli / "results.csv").read_bytes()
    table = read_csv(cli / "results.csv")
    for name, values in outcome.result.signals.items():
        assert np.array_equal(table[name], values), name
    assert outcome.out == api
    assert api / "results.csv" in outcome.files
    execution = json.loads((api / "run.json").read_text(encoding="utf-8"))["execution"]
    assert execution["isolate"] == "fmus"  # the CLI's default, applied by the API too
    assert execution["isolate_default"] is True


def test_the_api_isolates_fmus_by_default_so_a_crash_is_a_fault(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(
        SYSTEM.format(
            faulty=build_fixture_fmu("Faulty"), gain=build_fixture_fmu("Gain"), mode=SEGFAULT,
            stop=1.0, step=0.01, fail_at=0.3,
        ),
        encoding="utf-8",
    )  # fmt: skip
    result = fmionnx.load(path).run()  # a segfault here would end the test process
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "bad"
    assert "crashed with SIGSEGV in fmi2DoStep" in str(result.error)  # named: it was isolated
    assert result.time[-1] == pytest.approx(0.3)
    assert result.details["isolate"] == "fmus"


def test_options_of_another_backend_are_refused_as_the_cli_refuses_them(tmp_path: Path) -> None:
    system = loop_system(tmp_path, 0.1)
    with pytest.raises(
        RequestError, match="--sync applies to --backend ros2, not to --backend inprocess"
    ):
        fmionnx.run(system, sync="free", no_out=True)
    with pytest.raises(
        RequestError, match="--input-wait applies to --backend ros2 --sync free only"
    ):
        fmionnx.run(system, backend="ros2", input_wait=0.5, no_out=True)
    with pytest.raises(RequestError, match="--backend must be `inprocess` or `ros2`, not `gpu`"):
        fmionnx.run(system, backend="gpu", no_out=True)
