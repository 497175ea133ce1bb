"""Helpers forked from a single-threaded process instead of started as new interpreters
(``fmionnx/core/forking.py``): the isolated models' zygote and the plot worker.

A command's process has one BLAS thread (:func:`fmionnx.cli._one_blas_thread`) and forks
both; a process with another thread starts them as before. Either way a run's results and
figures are the same, byte for byte. Each case runs in a process of its own: pytest's own
process never forks a helper (``tests/conftest.py``).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fmionnx import cli
from tests.conftest import REPO, build_fixture_fmu, finish
from tests.processes import group_members
from tests.results.test_plot_worker import SYSTEM  # a signal, an FMU and two plots

#: Runs the system through the Python API (FMUs isolated, plots), with another thread when
#: asked, and prints how each helper was started, whether the plot worker had its own
#: process group as soon as it was made, and how the run ended.
RUN = """
import json, os, sys, threading
if sys.argv[1] == "threads":
    threading.Thread(target=threading.Event().wait, daemon=True).start()
os.sched_getaffinity = lambda _: {0, 1}  # a plot worker even on a machine of one core
import fmionnx
from fmionnx.results import plotworker
from fmionnx.runtime.isolated import launcher
seen = {}
made = plotworker.PlotWorker.__init__
def recording(self, **how):
    made(self, **how)
    pid = self._process.pid
    seen["plot worker"] = type(self._process).__name__
    seen["its own group"] = os.getpgid(pid) == pid != os.getpgrp()
plotworker.PlotWorker.__init__ = recording
outcome = fmionnx.run("system.yaml", out=sys.argv[1], isolate="fmus", plot=True)
seen["zygote"] = type(launcher._zygote.get()._process).__name__
seen["status"] = outcome.status.value
print(json.dumps(seen))
"""


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    return tmp_path


def _environment(**more: str) -> dict[str, str]:
    """This environment without a BLAS thread count (the command's own choice is tested)."""
    inherited = {k: v for k, v in os.environ.items() if k != cli.BLAS_THREADS}
    return {**inherited, "PYTHONPATH": str(REPO), **more}


def _api_run(folder: Path, mode: str) -> dict[str, object]:
    process = subprocess.Popen(
        [sys.executable, "-c", RUN, mode],
        cwd=folder,
        env=_environment(OPENBLAS_NUM_THREADS="1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    out, err = finish(process, 180)
    assert process.returncode == 0, err
    assert "Traceback" not in err, err
    seen: dict[str, object] = json.loads(out.strip().splitlines()[-1])
    return seen


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".csv", ".png")}


def test_a_single_threaded_process_forks_its_helpers_and_the_results_are_the_same(
    folder: Path,
) -> None:
    forked = _api_run(folder, "forked")
    started = _api_run(folder, "threads")
    assert forked == {
        "plot worker": "_ForkedWorker",
        "its own group": True,
        "zygote": "ForkedProcess",
        "status": "completed",
    }
    assert started == {
        "plot worker": "Popen",
        "its own group": True,
        "zygote": "Popen",
        "status": "completed",
    }
    files = _files(folder / "forked")
    assert set(files) == {
        "results.csv",
        "over-time.png",
        "one-against-the-other.png",
        "signals.png",
    }
    assert files == _files(folder / "threads")


#: Every Python process started with this on its path writes how it was started (forked
#: copies start no interpreter, so they write nothing).
STARTS = """
import json, os, sys
with open(os.environ["STARTS_LOG"], "a", encoding="utf-8") as log:
    log.write(json.dumps(sys.orig_argv) + "\\n")
"""


def test_the_command_forks_its_helpers(folder: Path) -> None:
    """``fmionnx run`` of a system with isolated FMUs and plots starts no interpreter for
    the zygote or the plot worker: its process has one BLAS thread, so it forks them."""
    site = folder / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(STARTS, encoding="utf-8")
    log = folder / "starts.log"
    environment = _environment(
        PYTHONPATH=os.pathsep.join([str(site), str(REPO)]), STARTS_LOG=str(log)
    )
    command = [sys.executable, "-m", "fmionnx", "run", "system.yaml", "--out", "out"]
    process = subprocess.Popen(
        command, cwd=folder, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    _, err = finish(process, 180)
    assert process.returncode == 0, err
    assert "Traceback" not in err, err
    starts = [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines()]
    assert [argv[1:4] for argv in starts] == [["-m", "fmionnx", "run"]], starts
    assert set(_files(folder / "out")) == {
        "results.csv",
        "over-time.png",
        "one-against-the-other.png",
    }


def test_the_command_gives_its_process_one_blas_thread_unless_told(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(cli.BLAS_THREADS, raising=False)
    cli._one_blas_thread()
    assert os.environ[cli.BLAS_THREADS] == "1"
    monkeypatch.setenv(cli.BLAS_THREADS, "4")
    cli._one_blas_thread()
    assert os.environ[cli.BLAS_THREADS] == "4"


LONG = """\
fmionnx: 1
name: long
run: {stop: 5000, step: 0.001}
components:
  integ: {kind: fmu, path: Integrator.fmu, parameters: {x0: 1.0, u: 0.5}}
  gain: {kind: fmu, path: Gain.fmu}
connections:
  - integ.x -> gain.u
plots:
  - {y: [integ.x, gain.y]}
"""


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_stop_signal_to_the_command_s_group_stops_it_cleanly(
    folder: Path, signum: signal.Signals, code: int
) -> None:
    """A terminal's Ctrl-C (or a service manager's SIGTERM) reaches the whole group, the
    forked zygote and its children too: the run ends as stopped, with its results and no
    traceback, and nothing of the group is left."""
    shutil.copy(build_fixture_fmu("Integrator"), folder / "Integrator.fmu")
    (folder / "long.yaml").write_text(LONG, encoding="utf-8")
    command = [sys.executable, "-m", "fmionnx", "run", "long.yaml", "--out", "out"]
    process = subprocess.Popen(
        command, cwd=folder, env=_environment(), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    assert process.stderr is not None
    for line in process.stderr:
        if "running long" in line:
            break
    time.sleep(1.0)  # well into the loop
    os.killpg(process.pid, signum)
    _, err = finish(process, 120)
    assert process.returncode == code, err
    assert f"interrupted by {signum.name}" in err
    assert "Traceback" not in err, err
    assert (folder / "out" / "results.csv").exists()
    deadline = time.monotonic() + 10
    while group_members(process.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert group_members(process.pid) == []
