"""``fmionnx.run(..., backend="ros2")`` from Python equals ``fmionnx run --backend ros2``:
the same pipeline, the same node processes, ``results.csv`` byte for byte (the API runs in a
fresh interpreter, which starts the nodes as the CLI does)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.pipeline.test_api_equals_cli import _api, _cli, _same_as_csv
from tests.ros2.test_run import loop_system, processes_with


@pytest.mark.ros2
def test_ros2_lockstep_over_dds_from_python_equals_the_cli(tmp_path: Path, loopback_env) -> None:
    system = loop_system(tmp_path, 1.0)
    cli, api = tmp_path / "cli", tmp_path / "api"
    _cli(system, cli, "--backend", "ros2", "--sync", "lockstep")
    result = _api(system, api, backend="ros2", sync="lockstep")
    assert result["status"] == "completed"
    assert (api / "results.csv").read_bytes() == (cli / "results.csv").read_bytes()
    _same_as_csv(result, cli / "results.csv")
    assert json.loads((api / "run.json").read_text())["backend"] == "ros2"
    assert processes_with(str(tmp_path)) == []
