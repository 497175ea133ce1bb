"""How the guardian's child and the guardian end: never a silent hang, never a lost result.

- a child that handed over its result and then hangs on its way out (a lock held by a
  thread of the parent at the fork, say) is killed after the grace period; its result is used;
- the CLI's progress bar runs no refresh thread under the guardian (nothing to hold a lock
  at the fork): the guardian's updates refresh it;
- the child says "abandoned, results written" only once its abandon callback has written
  them: a child that dies while writing them leaves the guardian to salvage the run.
"""

from __future__ import annotations

import io
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType, SimpleNamespace
from typing import Any

import pytest
from rich.console import Console
from rich.live import _RefreshThread

import fmionnx
from fmionnx.cli.run_report import TerminalReport
from fmionnx.pipeline.observers import RunStart
from fmionnx.runtime import guardian
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.result import RunOptions, RunStatus
from tests.backends.test_isolation import HANG, SYSTEM


class _HungError(Exception):
    pass


def test_a_child_hanging_after_its_result_is_killed_and_its_result_kept(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=0, stop=0.5, step=0.01,
            fail_at=10.0,
        )
    )  # fmt: skip
    system = fmionnx.load(path)
    child = guardian._child

    def child_then_hang(*args: Any) -> int:
        code = child(*args)
        time.sleep(30)  # stuck on the way out, after the result went down the pipe
        return code

    def alarm(signum: int, frame: FrameType | None) -> None:
        raise _HungError

    monkeypatch.setattr(guardian, "_child", child_then_hang)
    monkeypatch.setattr(guardian, "STOP_GRACE", 0.5)
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(20)
    try:
        result = run_guarded(system.compiled, system.run, RunOptions())
    except _HungError:
        pytest.fail("the guardian waited for a child that had handed over its result")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert result.status is RunStatus.COMPLETED
    assert result.steps_done == 50
    assert len(result.signals["bad.y"]) == 51


def test_the_progress_bar_runs_no_refresh_thread_under_the_guardian() -> None:
    run = SimpleNamespace(start=0.0, stop=1.0, steps=100)
    system = SimpleNamespace(name="demo", compiled=SimpleNamespace(run=run))
    threads: dict[bool, list[threading.Thread]] = {}
    output = io.StringIO()
    before = set(threading.enumerate())
    for guarded in (True, False):  # guarded first: the other's thread may outlive its bar
        report = TerminalReport(Path("demo.yaml"), quiet=False)
        report.console = Console(file=output, force_terminal=True, width=120)
        report.wants_progress = True
        start = RunStart(system, "inprocess", "", "", guarded, None)  # type: ignore[arg-type]
        report.before_run(start)
        # what is running when the guardian forks
        threads[guarded] = [
            t for t in threading.enumerate() if isinstance(t, _RefreshThread) and t not in before
        ]
        report.progress(50, 100, 0.5)
        report.after_run()
    assert threads[False]  # in-process: rich refreshes the bar on its own thread
    assert threads[True] == []
    assert "t =    0.500 / 1 s" in output.getvalue()


ABANDON_DIES = """
import os, sys
import fmionnx
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.result import RunOptions

system = fmionnx.load(sys.argv[1])

def abandon(result):
    os._exit(3)  # dies before the results are written

options = RunOptions(step_timeout=0.5, abandon=abandon, schedule="sequential")
result = run_guarded(system.compiled, system.run, options)
print("salvaged", result.status.value, result.steps_done, result.error.component)
"""


def _hanging_run_script(
    script: str, fixture_fmu: Callable[[str], Path], write_system: Callable[[str], Path]
) -> subprocess.CompletedProcess[str]:
    """``script`` run by a fresh interpreter on a system whose `bad` model hangs at 0.3 s."""
    path = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=HANG, stop=1.0,
            step=0.01, fail_at=0.3,
        )
    )  # fmt: skip
    return subprocess.run(
        [sys.executable, "-c", script, str(path)],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_a_child_dying_while_writing_abandoned_results_is_salvaged(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    process = _hanging_run_script(ABANDON_DIES, fixture_fmu, write_system)
    # the guardian did not take "abandoned" for "written": it wrote the salvaged run itself
    assert process.returncode == 0, process.stderr
    assert process.stdout.split() == ["salvaged", "fault", "30", "bad+gain"], process.stdout


ABANDON_WRITES = """
import contextlib, sys
import fmionnx
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.result import RunOptions

system = fmionnx.load(sys.argv[1])

def abandon(result):
    print("written by the child", result.error.component, flush=True)

@contextlib.contextmanager
def display():  # stands for the CLI's progress display: it must be taken down
    try:
        yield
    finally:
        print("display taken down", flush=True)

options = RunOptions(step_timeout=0.5, abandon=abandon, schedule="sequential")
try:
    with display():
        run_guarded(system.compiled, system.run, options)
except SystemExit as exc:
    print("exit status", exc.code)
"""


def test_an_abandoned_run_ends_the_guardian_through_its_callers_clean_up(
    fixture_fmu, write_system
) -> None:
    process = _hanging_run_script(ABANDON_WRITES, fixture_fmu, write_system)
    assert process.returncode == 0, process.stderr
    assert process.stdout.splitlines() == [
        "written by the child bad+gain",
        "display taken down",
        "exit status 1",
    ], process.stdout
