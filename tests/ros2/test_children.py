"""The supervisor's node processes: which ones have not ended, named when a run faults because
nodes did not end after the stop time (each node logs to ``logs/<component>.log``)."""

from __future__ import annotations

import sys
from pathlib import Path

from fmionnx.backends.ros2.supervisor import Children, not_ended_message


def test_the_nodes_still_running_are_named(tmp_path: Path) -> None:
    children = Children(tmp_path / "logs")
    children.start("quick", [sys.executable, "-c", "pass"])
    children.start("stuck", [sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        assert not children.wait_all(3.0)
        assert children.running() == ["stuck"]
    finally:
        children.stop()
    assert children.running() == []
    assert (tmp_path / "logs" / "stuck.log").exists()


def test_the_fault_names_each_node_that_did_not_end_and_its_log() -> None:
    message = not_ended_message(["tracker", "world"])
    assert message == (
        "nodes did not end within 60 s after the stop time: "
        "`tracker` (logs/tracker.log), `world` (logs/world.log)"
    )
