"""tests.conftest.end_process: a test's child is reaped and its pipes closed, however it ended."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import end_process


def _child(code: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def test_a_child_that_ended_by_itself_has_its_pipes_closed() -> None:
    child = _child("print('done')")
    child.wait(timeout=30)
    end_process(child)
    assert child.stdout is not None
    assert child.stdout.closed
    assert child.stderr is not None
    assert child.stderr.closed


def test_a_child_still_running_is_killed_and_reaped() -> None:
    child = _child("import time; print('up', flush=True); time.sleep(600)")
    assert child.stdout is not None
    assert child.stdout.readline() == "up\n"
    end_process(child)
    assert child.returncode is not None
    assert child.returncode < 0
    assert child.stdout.closed


def test_nothing_to_end() -> None:
    end_process(None)
