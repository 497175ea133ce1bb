"""The step timeout holds for every phase of every kind, isolated or not (docs/security.md).

A model may never return while it is loaded, initialized, stepped or terminated. Each case
here is a real model that hangs (a Faulty FMU built from C that spins in its initialization,
an ONNX model whose ``Loop`` never ends) or a real runner whose ``terminate`` is made to
hang (the runner is the timeout's peer here, not the part under test). The run must end at
the step timeout with a fault naming the component and the phase, and with the results of
the steps completed before it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import fmionnx
from fmionnx.kinds.onnx.ortsetup import onnxruntime_module
from fmionnx.runtime.result import RunOptions, RunStatus
from tests.security.hostile import endless_loop

#: Seconds of the step timeout in these tests: long enough for a real model to load on a
#: loaded machine (loading is timed too), short enough for the suite.
TIMEOUT = 5
#: Seconds a test's own process may take before it counts as hung.
WAIT = 90

FAULTY_SYSTEM = """
fmionnx: 1
name: hangs
run: {{stop: 1, step: 0.1}}
components:
  f: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}}}}}
"""

ONNX_SYSTEM = """
fmionnx: 1
name: endless
run: {stop: 1, step: 0.1}
components:
  source: {kind: signal, outputs: {x: {step: {time: 0.45}}}}
  net: {kind: onnx, path: endless.onnx}
connections:
  - source.x -> net.x
record: [source.x, net.y]
"""


@pytest.fixture(autouse=True)
def _onnxruntime_imported() -> None:
    """onnxruntime imported before the in-process runs: its first import (a second or more on
    a loaded machine) happens while the model loads, which the short step timeout here
    times."""
    onnxruntime_module()


def _cli(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fmionnx", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=WAIT,
        check=False,
        cwd=cwd,
    )


@pytest.mark.parametrize(
    "isolate",
    [(), ("--isolate", "none"), ("--isolate", "fmus")],
    ids=["default-guardian", "in-process", "isolated"],
)
def test_an_fmu_hanging_in_initialization_is_stopped_at_the_step_timeout(
    tmp_path: Path, fixture_fmu, isolate: tuple[str, ...]
) -> None:
    system = tmp_path / "hangs.yaml"
    system.write_text(FAULTY_SYSTEM.format(faulty=fixture_fmu("Faulty"), mode=12), "utf-8")
    out = tmp_path / "out"
    done = _cli("run", system, "--step-timeout", str(TIMEOUT), *isolate, "--out", out, "-q",
                cwd=tmp_path)  # fmt: skip
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    run = json.loads((out / "run.json").read_text("utf-8"))
    assert run["status"] == "fault"
    message = run["error"]["message"]
    assert run["error"]["component"] == "f"
    assert "initialization did not return within 5 s (the step timeout)" in message
    assert (out / "results.csv").is_file()


def test_an_onnx_loop_that_never_ends_in_initialization_is_stopped_in_this_process(
    tmp_path: Path,
) -> None:
    endless_loop(tmp_path / "endless.onnx")
    system = tmp_path / "endless.yaml"
    system.write_text(
        "fmionnx: 1\nname: endless\nrun: {stop: 1, step: 0.1}\n"
        "components:\n  net: {kind: onnx, path: endless.onnx}\n",
        "utf-8",
    )
    result = fmionnx.load(system).run(options=RunOptions(step_timeout=2))
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "net"
    assert "its initialization did not return within 2 s (the step timeout); it was stopped" in (
        str(result.error)
    )


def test_an_onnx_loop_that_never_ends_in_a_step_keeps_the_steps_before(tmp_path: Path) -> None:
    endless_loop(tmp_path / "endless.onnx", above=0.5)
    system = tmp_path / "endless.yaml"
    system.write_text(ONNX_SYSTEM, "utf-8")
    result = fmionnx.load(system).run(options=RunOptions(step_timeout=2, schedule="sequential"))
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert "a step did not return within 2 s (the step timeout); it was stopped" in str(
        result.error
    )
    # The source's step to 1 at 0.45 s is its output from the step at 0.4 s on: the network's
    # step at 0.4 s never ends; the four before it are kept.
    assert result.error.time == pytest.approx(0.4)
    assert result.steps_done == 4
    assert list(result["source.x"]) == [0.0] * 5
    assert list(result["net.y[0]"]) == [0.0] * 5


HANGING_TERMINATE = """
import json, sys, threading
import fmionnx
from fmionnx.kinds.registry import make_runner
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions

compiled = fmionnx.load(sys.argv[1]).compiled

def factory(component, wiring):
    runner = make_runner(component, wiring)
    runner.terminate = lambda: threading.Event().wait()  # never returns
    return runner

def abandoned(result):
    print(json.dumps({"status": result.status.value, "steps": result.steps_done,
                      "error": str(result.error)}), flush=True)

Master(compiled, RunOptions(step_timeout=2, abandon=abandoned), factory).run()
print("returned")
"""


def test_a_hang_in_terminate_keeps_every_step(tmp_path: Path, fixture_fmu) -> None:
    system = tmp_path / "gain.yaml"
    system.write_text(
        f"fmionnx: 1\nname: gain\nrun: {{stop: 1, step: 0.1}}\n"
        f"components:\n  g: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n",
        "utf-8",
    )
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(HANGING_TERMINATE), str(system)],
        capture_output=True, text=True, timeout=WAIT, check=False,
    )  # fmt: skip
    assert done.returncode == 1, done.stderr
    report = json.loads(done.stdout.splitlines()[0])
    assert report["status"] == "fault"
    assert report["steps"] == 10
    assert "its termination did not return within 2 s" in report["error"]
    assert "returned" not in done.stdout
