"""benchmarks/scenario.py's schedule comparison, floor and GIL probe compute the right things.

Timings are never asserted; what is checked is what each part measures and compares.
"""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from benchmarks import report, scenario
from tests.conftest import built_model


@pytest.fixture(scope="module")
def compared() -> scenario.Schedules:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    return scenario.schedules(0.2, 1)


def test_every_schedule_runs_to_the_same_results_and_the_floor_replays_the_run(compared) -> None:
    assert compared.identical
    rows = {row["configuration"]: row for row in scenario.schedule_rows(compared)}
    assert set(rows) == {label for label, _, _ in scenario.CONFIGURATIONS}
    assert rows["isolated FMUs, parallel"]["concurrent_steps"] == 2  # odometry, once per frame
    assert rows["isolated FMUs, sequential"]["concurrent_steps"] == 0
    assert compared.floor is not None
    assert (compared.floor.steps, compared.floor.frames) == (100, 2)  # 0.2 s of 2 ms; 10 Hz
    assert compared.floor.total > 0
    floor = scenario.floor_rows(compared)
    assert [row["call"] for row in floor][-1] == "sum"
    assert floor[-1]["seconds"] == pytest.approx(sum(row["seconds"] for row in floor[:-1]))
    targets = scenario.schedule_targets(compared)
    assert [t["limit"] for t in targets] == ["<= 0.8", "<= 0.8", ">= 6", "identical"]
    # Issue 32's target is the CLI's default: the FMUs isolated, the parallel schedule.
    assert targets[1]["value"] == rows["isolated FMUs, parallel"]["vs_floor"]
    text = io.StringIO()
    scenario.print_schedules(Console(file=text, width=200), compared, 1, report)
    assert "results identical: yes" in text.getvalue()


def test_gil_probe_measures_each_heavy_call() -> None:
    built_model("sign_detector.onnx")
    rows = scenario.gil_probe(quick=True)
    assert [row["call"].split()[0] for row in rows] == [
        "time.sleep(2", "sum(range(300000))", "mujoco.mj_step", "mujoco.mjr_render",
        "mujoco.mjr_readPixels", "Renderer.render", "onnxruntime",
    ]  # fmt: skip
    assert all(0.0 <= row["other_thread"] <= 1.0 for row in rows)
    assert all(row["ms_per_call"] > 0 for row in rows)
    assert all(isinstance(row["releases_gil"], bool) for row in rows[2:])
