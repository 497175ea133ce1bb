"""A study's summary plots draw a case that did not complete as missing, never as a value: a
fault's or a timeout's metric is measured on what was recorded before it ended."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fmionnx.results import study_plots
from fmionnx.results.casetable import CaseTable


def _table(columns: dict[str, list[Any]]) -> CaseTable:
    return CaseTable(tuple(columns), tuple(zip(*columns.values(), strict=True)))


def _rows(table: CaseTable, keep: Any) -> CaseTable:
    """The rows of ``table`` whose record ``keep`` accepts."""
    chosen = [row for row, record in zip(table.rows, table.records(), strict=True) if keep(record)]
    return CaseTable(table.columns, tuple(chosen))


#: Two targets on a 2 x 2 grid; one case faulted at load (its metric measured at t = 0).
COLUMNS: dict[str, list[Any]] = {
    "k": [1.0, 2.0, 1.0, 2.0],
    "x0": [0.0, 0.0, 0.5, 0.5],
    "y_end": [1.0, 2.0, 0.0, 3.0],
    "status": ["ok", "ok", "fault", "ok"],
}
GRID = _table(COLUMNS)


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures the plots would save (matplotlib draws them for real; the file is left)."""
    figures: list[Any] = []

    def keep(figure: Any, path: Path) -> Path:
        figures.append(figure)
        return path

    monkeypatch.setattr(study_plots, "save_figure", keep)
    return figures


def test_a_heat_map_leaves_a_case_that_did_not_complete_grey_and_says_why(
    drawn: list[Any], tmp_path: Path
) -> None:
    study_plots._heatmap(GRID, ["k", "x0"], "y_end", {}, tmp_path)
    axes = drawn[0].axes[0]
    cells = axes.images[0].get_array()
    assert cells[0].tolist() == [1.0, 2.0]  # x0 = 0: both completed
    assert np.ma.is_masked(cells[1, 0]) or math.isnan(float(cells[1, 0]))  # the fault
    assert cells[1, 1] == 3.0
    texts = {(t.get_position(), t.get_text()) for t in axes.texts}
    assert ((0, 1), "fault") in texts
    assert ((0, 1), "0") not in texts  # its recorded value is not shown as the case's
    assert axes.images[0].get_clim() == (1.0, 3.0)


def test_a_metric_against_a_target_marks_a_case_that_did_not_complete_at_the_foot(
    drawn: list[Any], tmp_path: Path
) -> None:
    table = _rows(GRID, lambda r: r["x0"] == 0.5)  # k = 1 faulted, k = 2 completed
    study_plots._against(table, ["k"], "y_end", {}, tmp_path)
    axes = drawn[0].axes[0]
    values, crosses = axes.lines
    assert values.get_xdata().tolist() == [1.0, 2.0]
    assert math.isnan(values.get_ydata()[0])
    assert values.get_ydata()[1] == 3.0
    assert crosses.get_xdata().tolist() == [1.0]
    assert crosses.get_label() == "did not complete"


def test_completed_cases_only_draw_as_before(drawn: list[Any], tmp_path: Path) -> None:
    table = _table({**COLUMNS, "status": ["ok"] * 4})
    study_plots._against(table, ["k", "x0"], "y_end", {}, tmp_path)
    for axes in drawn[0].axes:
        assert len(axes.lines) == 1  # no crosses, no legend
        assert axes.get_legend() is None
    assert sorted(drawn[0].axes[0].lines[0].get_ydata().tolist()) == [0.0, 1.0, 2.0, 3.0]


#: A case that completed without a value (a ``first_time`` whose condition never held).
NO_VALUE = _table({**COLUMNS, "y_end": [1.0, 2.0, float("nan"), 3.0], "status": ["ok"] * 4})
NAMES = {"k": "k [N/m]", "x0": "x0 [m]", "y_end": "y_end [m]"}


def test_a_heat_map_labels_a_completed_case_without_a_value(
    drawn: list[Any], tmp_path: Path
) -> None:
    study_plots._heatmap(NO_VALUE, ["k", "x0"], "y_end", NAMES, tmp_path)
    axes = drawn[0].axes[0]
    texts = {(t.get_position(), t.get_text()) for t in axes.texts}
    assert ((0, 1), "no value") in texts


def test_a_metric_against_a_target_marks_a_case_without_a_value(
    drawn: list[Any], tmp_path: Path
) -> None:
    study_plots._against(_rows(NO_VALUE, lambda r: r["x0"] == 0.5), ["k"], "y_end", NAMES, tmp_path)
    axes = drawn[0].axes[0]
    (cross,) = [line for line in axes.lines if line.get_gid() == "no value"]
    assert cross.get_xdata().tolist() == [1.0]
    assert cross.get_label() == "no value"


#: Cases whose metric was infinite (a record keeps `inf`, `-inf`).
INFINITE = _table(
    {**COLUMNS, "y_end": [float("inf"), 2.0, float("-inf"), 3.0], "status": ["ok"] * 4}
)


def test_a_heat_map_labels_infinite_values_and_keeps_a_finite_colour_scale(
    drawn: list[Any], tmp_path: Path
) -> None:
    """An infinite metric made a cell "inf" on grey with no sign, and could stretch the
    colour scale (a bug hunt)."""
    study_plots._heatmap(INFINITE, ["k", "x0"], "y_end", NAMES, tmp_path)
    axes = drawn[0].axes[0]
    texts = {(t.get_position(), t.get_text()) for t in axes.texts}
    assert ((0, 0), "inf") in texts
    assert ((0, 1), "-inf") in texts
    assert axes.images[0].get_clim() == (2.0, 3.0)


def test_a_metric_against_a_target_marks_infinite_values_at_the_edges(
    drawn: list[Any], tmp_path: Path
) -> None:
    """matplotlib leaves an infinite point out of a line, unmarked (a bug hunt)."""
    study_plots._against(INFINITE, ["k"], "y_end", NAMES, tmp_path)
    axes = drawn[0].axes[0]
    marks = {line.get_gid(): line for line in axes.lines if line.get_gid() in ("inf", "-inf")}
    assert marks["inf"].get_marker() == "^"
    assert marks["-inf"].get_marker() == "v"
    assert marks["inf"].get_ydata().tolist() == [0.97]
    assert marks["-inf"].get_ydata().tolist() == [0.03]
    assert axes.get_legend() is not None
    assert all(math.isfinite(v) or math.isnan(v) for v in axes.lines[0].get_ydata())


def test_axes_and_colour_bars_carry_units(drawn: list[Any], tmp_path: Path) -> None:
    study_plots._heatmap(GRID, ["k", "x0"], "y_end", NAMES, tmp_path)
    axes, bar = drawn[0].axes
    assert (axes.get_xlabel(), axes.get_ylabel()) == ("k [N/m]", "x0 [m]")
    assert bar.get_ylabel() == "y_end [m]"
    study_plots._against(GRID, ["k"], "y_end", NAMES, tmp_path)
    assert (drawn[1].axes[0].get_xlabel(), drawn[1].axes[0].get_ylabel()) == (
        "k [N/m]",
        "y_end [m]",
    )


def test_units_of_targets_and_metrics_follow_the_models() -> None:
    """The reference study: the tracker's parameters and three measures."""
    from fmionnx.compile.study import compile_study
    from fmionnx.core.diagnostics import DiagnosticBag
    from fmionnx.results.study_units import plan_units
    from fmionnx.spec.study import load_study
    from tests.conftest import REPO

    bag = DiagnosticBag()
    plan = compile_study(load_study(REPO / "examples" / "sweep-tracker" / "study.yaml", bag), bag)
    assert plan is not None, [str(d) for d in bag]
    assert plan_units(plan) == {
        "tracker.cruiseSpeed": "m/s",
        "tracker.turnRate": "rad/s",
        "distance_to_B": "m",
        "time_to_B": "s",
        "max_deviation": "m",
    }
