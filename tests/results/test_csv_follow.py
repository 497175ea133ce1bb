"""``results.csv`` formatted by the plot worker while an in-process run goes on
(:mod:`fmionnx.results.csvfollow`).

The rows the run records into the shared file read back as the result's, the pieces made
from them give the very bytes of a file formatted at the end, the worker writes the file
itself when it followed, and the run's process writes it when the worker cannot.
"""

from __future__ import annotations

import os
import shutil
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.results import csvahead, csvfile, csvfollow, plotworker
from fmionnx.results.csvahead import CsvAhead
from fmionnx.results.csvfile import result_table, write_csv
from fmionnx.runtime import guardian
from fmionnx.runtime.guardian import RowsShared, follow_rows
from fmionnx.runtime.instruments import Instruments
from fmionnx.runtime.result import RunOptions
from tests.backends.test_native_group import _multi_rate
from tests.conftest import build_fixture_fmu
from tests.results.test_plot_worker import SYSTEM


def _longer(path: Path, steps: int, interval: str = "") -> Path:
    text = path.read_text(encoding="utf-8")
    run = f"run: {{stop: {steps * 0.01:g}, step: 0.01{interval}}}"
    path.write_text(text.replace("run: {stop: 0.6, step: 0.01}", run), encoding="utf-8")
    return path


@pytest.mark.parametrize("interval", ["", ", output_interval: 0.03"])
def test_rows_recorded_for_a_follower_give_the_same_file(
    fixture_fmu, write_system, tmp_path: Path, interval: str
) -> None:
    """Several rates, held values, an output interval, tracks that grew while recorded: the
    pieces formatted from the shared file are all used, and the file is byte for byte the
    one formatted at the end."""
    steps = 70_000  # beyond the 65 536 rows a track reserves first: it moved once
    path = _longer(_multi_rate(fixture_fmu, write_system), steps, interval)
    system = fmionnx.load(path)
    rows = RowsShared()
    try:
        options = RunOptions(instruments=Instruments(recorder=rows.recorder))
        result = system.run(options=options)
        published = follow_rows(rows.fd, system.compiled.run.steps)
        assert published is not None
        every = system.compiled.run.output_every
        ahead = CsvAhead(system.compiled.run.start, 0.01, every, piece_rows=1024)
        stop = threading.Event()
        thread = threading.Thread(target=csvfollow.format_published, args=(ahead, published, stop))
        thread.start()
        table_rows = len(result.time)
        deadline = time.monotonic() + 60
        while ahead.rows < table_rows // 1024 * 1024 and time.monotonic() < deadline:
            time.sleep(0.01)
        stop.set()
        thread.join()
        published.close()
    finally:
        rows.close()
    assert ahead.rows == table_rows // 1024 * 1024  # every whole piece, formatted ahead
    table = result_table(result)
    for first in range(0, ahead.rows, 1024):  # ... and each holds the result's values
        assert ahead.text(table, first) is not None
    followed = write_csv(result, tmp_path / "followed.csv", ahead=ahead).read_bytes()
    assert followed == write_csv(result, tmp_path / "end.csv").read_bytes()


def test_a_file_that_could_shrink_is_not_followed(tmp_path: Path) -> None:
    """Only a sealed file is mapped: one that could be truncated under the mapping would
    kill the worker (SIGBUS)."""
    fd = os.memfd_create("unsealed")
    try:
        os.ftruncate(fd, 1 << 20)
        assert follow_rows(fd, 100) is None
    finally:
        os.close(fd)


def test_closing_the_rows_twice_closes_nothing_else(tmp_path: Path) -> None:
    """The plot worker closes its rows when it is collected and again when the run ends: a
    second ``os.close`` of the number closed whichever file had it by then (a pipe a later
    fork needed: a test hung)."""
    rows = RowsShared()
    number = rows.fd
    rows.close()
    with (tmp_path / "other").open("w") as other:
        assert other.fileno() == number  # the lowest free number: the one just closed
        rows.close()
        os.fstat(other.fileno())  # still open


def test_the_follower_thread_yields_to_the_run() -> None:
    seen: list[int] = []

    def body() -> None:
        csvfollow.lower_priority()
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))

    before = os.getpriority(os.PRIO_PROCESS, 0)
    thread = threading.Thread(target=body)
    thread.start()
    thread.join()
    assert seen == [max(before, csvfollow.FOLLOWER_NICE)]
    assert os.getpriority(os.PRIO_PROCESS, 0) == before  # the caller's own thread: as it was


def test_pieces_follow_the_length_of_the_run() -> None:
    def piece(steps: int, every: int = 1) -> int:
        return csvfollow.FollowRows(3, steps, 0.0, 0.01, every).piece_rows

    assert piece(16_000) == csvfollow.MIN_PIECE_ROWS  # the reference run: 15 pieces ahead
    assert piece(50_000) == 50_001 // csvfollow.PIECES_PER_RUN
    assert piece(10_000_000) == csvfollow.MAX_PIECE_ROWS  # the job waits for one at most
    assert piece(100_000, every=10) == csvfollow.MIN_PIECE_ROWS


def test_following_by_default_only_with_a_core_to_spare(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(csvahead.SWITCH, raising=False)
    monkeypatch.setattr(csvfollow, "usable_cores", lambda: 2)
    assert not csvfollow.wanted()
    monkeypatch.setattr(csvfollow, "usable_cores", lambda: 3)
    assert csvfollow.wanted()
    monkeypatch.setenv(csvahead.SWITCH, "0")
    assert not csvfollow.wanted()
    monkeypatch.setattr(csvfollow, "usable_cores", lambda: 2)
    monkeypatch.setenv(csvahead.SWITCH, "1")
    assert csvfollow.wanted()
    monkeypatch.setattr(guardian, "available", lambda: "no memfd_create here")
    assert not csvfollow.wanted()  # nothing to record into (off Linux)


# -- through the plot worker -------------------------------------------------------------------


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    longer = SYSTEM.replace("run: {stop: 2, step: 0.01}", "run: {stop: 40, step: 0.01}")
    (tmp_path / "system.yaml").write_text(longer, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(plotworker.os, "sched_getaffinity", lambda _: {0, 1})
    return tmp_path


@pytest.fixture
def workers(monkeypatch: pytest.MonkeyPatch) -> list[plotworker.PlotWorker]:
    """Every plot worker the runs start (real ones)."""
    started: list[plotworker.PlotWorker] = []

    def counting(**how: Any) -> plotworker.PlotWorker:
        worker = plotworker.PlotWorker(**how)
        started.append(worker)
        return worker

    monkeypatch.setattr(plotworker, "start", counting)
    return started


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".csv", ".png")}


def test_the_worker_writes_the_results_csv_it_followed(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(csvahead.SWITCH, "1")

    def not_here(*args: object, **kwargs: object) -> Path:
        raise AssertionError("results.csv written by the run's process")

    with monkeypatch.context() as patch:
        patch.setattr(csvfile, "write_csv", not_here)
        followed = fmionnx.run("system.yaml", out=Path("followed"), isolate="none")
    (worker,) = workers
    assert worker.rows is not None  # it followed (and has let go of the file since)
    monkeypatch.setenv(csvahead.SWITCH, "0")
    at_end = fmionnx.run("system.yaml", out=Path("end"), isolate="none")
    assert workers[1].rows is None
    assert _files(folder / "followed") == _files(folder / "end")
    assert [p.name for p in followed.files] == [p.name for p in at_end.files]  # same order
    assert followed.files[0].name == "results.csv"


def test_rows_are_formatted_while_the_run_goes_on(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A run paced to last 3 s: the worker has imported matplotlib long before it ends, and
    formats pieces of 1 024 rows as they are published."""
    monkeypatch.setenv(csvahead.SWITCH, "1")
    fmionnx.run("system.yaml", out=Path("paced"), isolate="none", stop_time=60, rtf=20)
    (worker,) = workers
    assert worker.rows_ahead >= csvfollow.MIN_PIECE_ROWS


def test_a_shared_file_that_cannot_be_had_leaves_the_worker_drawing(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(csvahead.SWITCH, "1")

    def no_memfd() -> None:
        raise OSError(24, "Too many open files")

    monkeypatch.setattr(guardian, "RowsShared", no_memfd)
    fmionnx.run("system.yaml", out=Path("private"), isolate="none")
    (worker,) = workers
    assert worker.rows is None  # recorded privately, formatted here at the end
    assert {p.name for p in (folder / "private").iterdir()} >= {
        "results.csv", "over-time.png", "one-against-the-other.png",
    }  # fmt: skip


def test_a_worker_that_dies_with_the_job_leaves_results_csv_to_the_run(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(csvahead.SWITCH, "1")
    real_collect = plotworker.PlotWorker.collect

    def kill_then_collect(self: plotworker.PlotWorker) -> list[Path] | None:
        assert self._process is not None
        os.kill(self._process.pid, signal.SIGKILL)
        self._process.wait()
        return real_collect(self)

    with monkeypatch.context() as patch:
        patch.setattr(plotworker.PlotWorker, "collect", kill_then_collect)
        fmionnx.run("system.yaml", out=Path("fallback"), isolate="none")
    assert workers[0].rows is not None  # it was following when it died
    monkeypatch.setenv(csvahead.SWITCH, "0")
    fmionnx.run("system.yaml", out=Path("end"), isolate="none")
    assert _files(folder / "fallback") == _files(folder / "end")


def test_a_run_watched_live_is_not_followed(
    folder: Path, workers: list[plotworker.PlotWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The live views' feed records the run itself: the worker then does not follow."""
    pytest.importorskip("rerun")
    monkeypatch.setenv(csvahead.SWITCH, "1")
    fmionnx.run("system.yaml", out=Path("viewed"), isolate="none", rrd=Path("run.rrd"))
    (worker,) = workers
    assert worker.rows is None
    assert (folder / "viewed" / "results.csv").exists()
