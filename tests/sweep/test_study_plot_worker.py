"""A study's plots are drawn by a plot worker started with the study (issue #32): the same
files, byte for byte, as drawn in the study's own process; drawn there when the worker is
gone; no worker left once the study ends."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

import fmionnx
from fmionnx.results import plotworker, study_plots
from tests.sweep.conftest import WriteStudy

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

GRID = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [0.5, 2]
  integ.x0: [0, 1]
metrics:
  y_end: final(gain.y)
  y_mean: mean(gain.y)
"""
#: Two targets on a grid: a heat map per metric, and the checks' pass/fail map.
FIGURES = {"heatmap-y_end.png", "heatmap-y_mean.png", "passfail.png"}


@pytest.fixture
def workers(monkeypatch: pytest.MonkeyPatch) -> list[plotworker.PlotWorker]:
    """Every plot worker the studies start (real ones), on this machine whatever its cores."""
    started: list[plotworker.PlotWorker] = []

    def counting(*, study: bool = False) -> plotworker.PlotWorker:
        worker = plotworker.PlotWorker(study=study)
        started.append(worker)
        return worker

    monkeypatch.setattr(plotworker, "start", counting)
    return started


def _figures(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix == ".png"}


def test_the_worker_draws_the_same_plots_as_the_study_itself(
    write_study: WriteStudy,
    tmp_path: Path,
    cluster: str,
    workers: list[plotworker.PlotWorker],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    study = write_study(GRID)

    def not_here(*_: object) -> list[Path]:
        raise AssertionError("drawn in the study's process although a worker was there")

    with monkeypatch.context() as patch:
        patch.setattr(study_plots, "write_study_plots", not_here)
        fmionnx.sweep(study, out=tmp_path / "worker", scheduler=cluster)
    assert len(workers) == 1
    assert workers[0]._process is None  # closed: waited for, nothing left running
    monkeypatch.setenv(plotworker.SWITCH, "0")
    monkeypatch.setattr(plotworker, "start", lambda **_: None)  # as start() does when off
    fmionnx.sweep(study, out=tmp_path / "here", scheduler=cluster)
    drawn = _figures(tmp_path / "worker")
    assert set(drawn) == FIGURES
    assert drawn == _figures(tmp_path / "here")
    owned = (tmp_path / "worker" / ".fmionnx-owned").read_text("utf-8")
    assert all(name in owned for name in FIGURES)  # a later --force may remove them


def test_a_worker_that_dies_leaves_the_plots_to_the_study(
    write_study: WriteStudy,
    tmp_path: Path,
    cluster: str,
    workers: list[plotworker.PlotWorker],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real_submit = plotworker.PlotWorker.submit

    def kill_then_submit(self: plotworker.PlotWorker, job: object) -> bool:
        assert self._process is not None
        os.kill(self._process.pid, signal.SIGKILL)
        self._process.wait()
        return real_submit(self, job)  # type: ignore[arg-type]

    monkeypatch.setattr(plotworker.PlotWorker, "submit", kill_then_submit)
    fmionnx.sweep(write_study(GRID), out=tmp_path / "out", scheduler=cluster)
    assert len(workers) == 1
    assert set(_figures(tmp_path / "out")) == FIGURES


def test_a_study_stopped_before_its_plots_leaves_no_worker(
    write_study: WriteStudy,
    tmp_path: Path,
    cluster: str,
    workers: list[plotworker.PlotWorker],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from fmionnx.results.study import StudyFolder

    def broken_table(self: StudyFolder) -> object:
        raise OSError("the disk is gone")

    monkeypatch.setattr(StudyFolder, "table", broken_table)
    with pytest.raises(OSError, match="the disk is gone"):
        fmionnx.sweep(write_study(GRID), out=tmp_path / "out", scheduler=cluster)
    (worker,) = workers
    assert worker._process is None
