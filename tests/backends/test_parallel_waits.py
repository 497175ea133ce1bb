"""Wherever the parallel loop waits for a lane, the watchdog sees that lane's step.

And when a repeated stop signal cuts the last wait short (the end of the run), the runner
whose step is still running on its lane is not freed under it.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import FrameType
from typing import Any

import pytest

import fmionnx
from fmionnx.core.runner import Runner, Wiring
from fmionnx.core.types import Component
from fmionnx.kinds.registry import make_runner
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions, RunStatus
from tests.backends.test_parallel_schedule import Probe, _run, _two_branches
from tests.conftest import REPO

SETTLE_HANG = """
import json, sys
from pathlib import Path
from tests.backends.test_parallel_schedule import Probe, _run

def abandon(result):
    Path(sys.argv[2]).write_text(json.dumps({
        "component": result.error.component, "time": result.error.time,
        "steps": result.steps_done, "signals": {k: v.tolist() for k, v in result.signals.items()},
    }))

probe = Probe(hang_at={"a": 0.03}, fail_at={"b": 0.03})
_run(Path(sys.argv[1]), probe, {"a", "b"}, step_timeout=1.0, abandon=abandon)
"""


def test_a_step_hanging_on_its_lane_while_the_loop_settles_a_fault_is_named(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    """b faults on the loop while a (on its lane, earlier in the order) hangs: the loop
    waits for a to settle the fault, and the watchdog names a, not b."""
    path = _two_branches(fixture_fmu, write_system, stop=0.1)
    written = tmp_path / "abandoned.json"
    process = subprocess.run(
        [sys.executable, "-c", SETTLE_HANG, str(path), str(written)],
        check=False, capture_output=True, text=True, timeout=120, cwd=REPO,
    )  # fmt: skip
    assert process.returncode == 1, process.stderr
    abandoned = json.loads(written.read_text())
    assert abandoned["component"] == "a"
    assert abandoned["time"] == pytest.approx(0.03)
    sequential = _run(path, Probe(fail_at={"a": 0.03}), {"a", "b"}, schedule="sequential")
    assert abandoned["steps"] == sequential.steps_done
    assert abandoned["signals"] == {k: v.tolist() for k, v in sequential.signals.items()}


class _Blocking:
    """A real runner on a lane whose step from 0.03 s waits for ``release``; it notes a
    ``terminate`` that comes while it steps (freeing a model under its own step)."""

    releases_gil = True

    def __init__(self, inner: Runner, release: threading.Event | None) -> None:
        self._inner, self._release = inner, release
        self.stepping = False
        self.freed_while_stepping = False

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def step(self, t: float, h: float) -> None:
        self.stepping = True
        if self._release is not None and t >= 0.03 - 1e-12:
            signal.setitimer(signal.ITIMER_REAL, 0.3, 0.3)  # Ctrl-C, again and again
            self._release.wait(30)
        self._inner.step(t, h)
        self.stepping = False

    def terminate(self) -> None:
        self.freed_while_stepping |= self.stepping
        self._inner.terminate()


def test_repeated_ctrl_c_does_not_free_a_runner_still_stepping_on_its_lane(
    fixture_fmu, write_system
) -> None:
    path = _two_branches(fixture_fmu, write_system, stop=0.1)
    release = threading.Event()
    made: dict[str, _Blocking] = {}

    def factory(component: Component, wiring: Wiring) -> Any:
        runner = make_runner(component, wiring)
        if component.name not in ("a", "b"):
            return runner
        # b wrapped too (not blocking), so that it is not stepped with the sinks natively:
        # then b, not the sinks reading a, follows a, and a's steps go to a lane
        made[component.name] = _Blocking(runner, release if component.name == "a" else None)
        return made[component.name]

    signals = []

    def interrupt(signum: int, frame: FrameType | None) -> None:
        # Ctrl-C three times: the loop's join, the drain after it, the end of the run
        signals.append(signum)
        if len(signals) == 3:
            signal.setitimer(signal.ITIMER_REAL, 0)
        raise KeyboardInterrupt

    master = Master(fmionnx.load(path).compiled, RunOptions(), factory)
    previous = signal.signal(signal.SIGALRM, interrupt)
    try:
        result = master.run()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        release.set()
    assert len(signals) == 3
    assert result.status is RunStatus.INTERRUPTED
    assert not made["a"].freed_while_stepping
