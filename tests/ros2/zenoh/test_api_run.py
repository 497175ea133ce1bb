"""``fmionnx.run(..., backend="ros2", middleware="zenoh")`` from Python equals the CLI's run
over Zenoh, byte for byte, and the in-process run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fmionnx.backends.ros2.zenoh.router import InProcessRouter
from tests.pipeline.test_api_equals_cli import _api, _cli, _same_as_csv
from tests.ros2.test_run import loop_system


@pytest.mark.ros2
def test_ros2_lockstep_over_zenoh_from_python_equals_the_cli(
    tmp_path: Path, router: InProcessRouter
) -> None:
    system = loop_system(tmp_path, 1.0)
    cli, api = tmp_path / "cli", tmp_path / "api"
    flags = ("--backend", "ros2", "--middleware", "zenoh", "--zenoh-router", router.endpoint)
    _cli(system, cli, *flags)
    result = _api(
        system, api, backend="ros2", middleware="zenoh", sync="lockstep",
        zenoh_router=router.endpoint,
    )  # fmt: skip
    assert (api / "results.csv").read_bytes() == (cli / "results.csv").read_bytes()
    _same_as_csv(result, cli / "results.csv")
    execution = json.loads((api / "run.json").read_text())["execution"]
    assert execution["middleware"] == "zenoh"
    inprocess = tmp_path / "inprocess"
    _cli(system, inprocess)
    assert (api / "results.csv").read_bytes() == (inprocess / "results.csv").read_bytes()
