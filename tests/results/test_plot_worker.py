"""Plots drawn by a worker process started before the run: the same files, byte for byte, as
drawn in the run's own process; none started when nothing is drawn; a worker that fails
leaves the drawing to the run's process."""

from __future__ import annotations

import ast
import os
import pickle
import shutil
import signal
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.results import plotworker
from tests.conftest import REPO, build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: drawn
run: {stop: 2, step: 0.01}
components:
  wave: {kind: signal, outputs: {y: {sine: {amplitude: 1, frequency: 0.5}}}}
  gain: {kind: fmu, path: Gain.fmu, parameters: {k: 3}}
connections:
  - wave.y -> gain.u
plots:
  - {y: [wave.y, gain.y], title: Over time}
  - {xy: [wave.y, gain.y], title: One against the other}
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.fixture
def workers(monkeypatch: pytest.MonkeyPatch) -> list[plotworker.PlotWorker]:
    """Every plot worker the runs start (real ones), on this machine whatever its cores."""
    started: list[plotworker.PlotWorker] = []

    def counting(**how: Any) -> plotworker.PlotWorker | None:
        if not plotworker.wanted():
            return None
        worker = plotworker.PlotWorker(**how)
        started.append(worker)
        return worker

    monkeypatch.setattr(plotworker, "start", counting)
    monkeypatch.setattr(plotworker.os, "sched_getaffinity", lambda _: {0, 1})
    return started


def drawn(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix == ".png"}


def test_the_worker_draws_the_same_files_as_the_run_itself(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    def not_here(job: plotworker.PlotJob) -> list[Path]:
        raise AssertionError("drawn in the run's process although a worker was there")

    with monkeypatch.context() as patch:
        patch.setattr(plotworker, "draw_here", not_here)
        worked = fmionnx.run("system.yaml", out=Path("worker"), isolate="none", plot=True)
    assert len(workers) == 1
    monkeypatch.setenv(plotworker.SWITCH, "0")
    here = fmionnx.run("system.yaml", out=Path("here"), isolate="none", plot=True)
    assert len(workers) == 1  # switched off: drawn in this process
    figures = drawn(folder / "worker")
    assert set(figures) == {"over-time.png", "one-against-the-other.png", "signals.png"}
    assert figures == drawn(folder / "here")
    assert [p.name for p in worked.files] == [p.name for p in here.files]  # same order
    assert (folder / "worker" / "run.json").read_text().count(".png") == 3


SYSTEM_WITH_PLOTS = "drawn.yaml"


def test_a_run_that_draws_nothing_starts_no_worker(
    folder: Path, workers: list[plotworker.PlotWorker]
) -> None:
    shutil.copy(folder / "system.yaml", folder / SYSTEM_WITH_PLOTS)
    (folder / "system.yaml").write_text(SYSTEM.split("plots:", maxsplit=1)[0], encoding="utf-8")
    fmionnx.run("system.yaml", out=Path("plain"), isolate="none")
    fmionnx.run(SYSTEM_WITH_PLOTS, no_out=True, isolate="none")  # nowhere to draw
    assert workers == []


def test_a_worker_that_dies_leaves_the_drawing_to_the_run(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    real_submit = plotworker.PlotWorker.submit

    def kill_then_submit(self: plotworker.PlotWorker, job: plotworker.PlotJob) -> bool:
        assert self._process is not None
        os.kill(self._process.pid, signal.SIGKILL)
        self._process.wait()
        return real_submit(self, job)

    monkeypatch.setattr(plotworker.PlotWorker, "submit", kill_then_submit)
    outcome = fmionnx.run("system.yaml", out=Path("fallback"), isolate="none")
    assert len(workers) == 1
    assert set(drawn(folder / "fallback")) == {"over-time.png", "one-against-the-other.png"}
    assert [p.name for p in outcome.files][:3] == [
        "results.csv",
        "over-time.png",
        "one-against-the-other.png",
    ]


def test_the_worker_is_gone_after_the_run(
    folder: Path, workers: list[plotworker.PlotWorker]
) -> None:
    fmionnx.run("system.yaml", out=Path("gone"), isolate="none")
    (worker,) = workers
    assert worker._process is None  # closed: waited for, nothing left running


def test_a_worker_whose_run_never_draws_ends_when_its_stdin_closes() -> None:
    """A run refused or faulted before its results: the worker is closed unused and exits
    by itself (it also does when its parent dies: its stdin closes then too)."""
    worker = plotworker.PlotWorker()
    process = worker._process
    assert process is not None
    worker.close()
    assert process.returncode == 0


def _modules_after_drawing(job: plotworker.PlotJob | plotworker.StudyPlotJob) -> set[str]:
    """The top-level modules a real worker process had imported once it drew ``job``."""
    study = isinstance(job, plotworker.StudyPlotJob)
    data = pickle.dumps(job)
    probe = (
        "import sys\n"
        "from fmionnx.results import plotworker\n"
        + ("sys.argv.append('--study')\n" if study else "")
        + "plotworker.main()\n"
        "print(sorted({m.split('.')[0] for m in sys.modules}), file=sys.stderr)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], input=struct.pack("<Q", len(data)) + data,
        capture_output=True, timeout=120, check=False,
    )  # fmt: skip
    errors = done.stderr.decode(errors="replace")
    assert done.returncode == 0, errors
    return set(ast.literal_eval(errors.strip().splitlines()[-1]))


def test_the_worker_imports_no_system_file_models(tmp_path: Path) -> None:
    """The worker unpickles a compiled system and a result, and draws: the system file's
    pydantic models (about 0.05 s of CPU to import) are not needed there, and a worker starts
    for every run that draws. The job is the reference system's (an FMU, an ONNX model, a
    MuJoCo scene: each kind's compiled settings unpickled)."""
    system = fmionnx.load(REPO / "systems" / "sign_follower.yaml")
    result = system.run(stop_time=0.05, isolate="none")
    job = plotworker.PlotJob(result, system.compiled, tmp_path, True, False)
    modules = _modules_after_drawing(job)
    assert len(list(tmp_path.glob("*.png"))) == 2  # the job was drawn
    assert "fmionnx" in modules
    assert "pydantic" not in modules


def test_a_study_worker_draws_without_pandas(tmp_path: Path) -> None:
    """A study's worker gets the table as rows (:mod:`fmionnx.results.casetable`) and draws
    with numpy and matplotlib: pandas (about 0.4 s of CPU) would be imported for nothing, on
    a machine the study's cases keep busy."""
    from fmionnx.compile.study import compile_study
    from fmionnx.core.diagnostics import DiagnosticBag
    from fmionnx.results.casetable import CaseTable
    from fmionnx.results.study import StudyFolder
    from fmionnx.spec.study import load_study

    bag = DiagnosticBag()
    plan = compile_study(load_study(REPO / "examples" / "sweep-tracker" / "study.yaml", bag), bag)
    assert plan is not None, [str(d) for d in bag]
    columns = StudyFolder(tmp_path, plan).table().columns
    rows = tuple(
        (case.id, *(s.value for s in case.settings), *(float(i),) * len(plan.metrics),
         *(i % 2 == 0,) * len(plan.check_names), "ok", "", 0.5, "worker")
        for i, case in enumerate(plan.cases)
    )  # fmt: skip
    modules = _modules_after_drawing(
        plotworker.StudyPlotJob(CaseTable(columns, rows), plan, tmp_path)
    )
    drawn = {p.name for p in tmp_path.glob("*.png")}
    assert drawn == {
        "heatmap-distance_to_B.png",
        "heatmap-time_to_B.png",
        "heatmap-max_deviation.png",
        "passfail.png",
    }
    assert "matplotlib" in modules
    assert "pandas" not in modules
