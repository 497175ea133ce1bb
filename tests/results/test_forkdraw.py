"""Figures drawn side by side by forked copies of the plot worker (issue #32): every figure
once, in order, by several processes; a copy that fails or dies fails the job; the copies'
log records come back; no copy is left behind."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from fmionnx.results.forkdraw import DrawingFailedError, draw_side_by_side, processes_for
from tests.processes import child_pids


def _drawing(folder: Path, index: int, logged: list[tuple[int, str]]) -> Callable[[], Path]:
    """A stand-in figure: writes which process drew it, and logs that it did."""

    def draw() -> Path:
        path = folder / f"{index}.txt"
        path.write_text(str(os.getpid()), "ascii")
        logged.append((20, f"drew {index}"))
        return path

    return draw


def _children() -> set[int]:
    """This process's child processes now (any thread's), zombies included."""
    return set(child_pids())


@pytest.fixture
def no_copy_left() -> Iterator[None]:
    """Every copy a test forks is reaped by the time it ends."""
    before = _children()
    yield
    assert _children() <= before


@pytest.mark.usefixtures("no_copy_left")
def test_each_figure_is_drawn_once_in_order_by_several_processes(tmp_path: Path) -> None:
    logged: list[tuple[int, str]] = []
    drawings = [_drawing(tmp_path, i, logged) for i in range(5)]
    files = draw_side_by_side(drawings, 3, logged)
    assert files == [tmp_path / f"{i}.txt" for i in range(5)]
    drawers = [int(f.read_text("ascii")) for f in files]
    assert len(set(drawers)) == 3
    assert drawers[0] == drawers[3] == os.getpid()  # this process draws every third
    assert drawers[1] == drawers[4] != drawers[2]
    assert sorted(message for _, message in logged) == [f"drew {i}" for i in range(5)]


def test_one_process_draws_alone(tmp_path: Path) -> None:
    logged: list[tuple[int, str]] = []
    files = draw_side_by_side([_drawing(tmp_path, i, logged) for i in range(2)], 1, logged)
    assert {int(f.read_text("ascii")) for f in files} == {os.getpid()}


@pytest.mark.usefixtures("no_copy_left")
def test_a_copy_that_raises_fails_the_job(tmp_path: Path) -> None:
    logged: list[tuple[int, str]] = []

    def broken() -> Path:
        raise ValueError("no such signal")

    with pytest.raises(DrawingFailedError, match="ValueError: no such signal"):
        draw_side_by_side([_drawing(tmp_path, 0, logged), broken], 2, logged)


@pytest.mark.usefixtures("no_copy_left")
def test_a_copy_that_dies_fails_the_job(tmp_path: Path) -> None:
    logged: list[tuple[int, str]] = []

    def dies() -> Path:
        os._exit(3)

    with pytest.raises(DrawingFailedError, match="ended without a report"):
        draw_side_by_side([_drawing(tmp_path, 0, logged), dies], 2, logged)


@pytest.mark.usefixtures("no_copy_left")
def test_the_copies_are_reaped_when_this_process_fails(tmp_path: Path) -> None:
    logged: list[tuple[int, str]] = []

    def broken() -> Path:
        raise KeyError("mine")

    with pytest.raises(KeyError, match="mine"):
        draw_side_by_side([broken, _drawing(tmp_path, 1, logged)], 2, logged)
    assert (tmp_path / "1.txt").exists()  # the copy finished its figure first


def test_processes_follow_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "sched_getaffinity", lambda _: {0, 1, 2, 3})
    assert processes_for(2) == 2
    assert processes_for(9) == 4
    assert processes_for(0) == 1
