"""Summary plots of a study (matplotlib, Agg): what a table of numbers hides at a glance.

* one target: each metric against it (``metric-<name>.png``);
* two targets: a heat map per metric over the grid (``heatmap-<name>.png``);
* more targets, or sampled ones: each metric against each target, as points;
* always, with checks: a pass/fail map (``passfail.png``) over the first two targets (or
  against the first one), green where the case ran and passed every check.

Cases that did not complete are drawn as missing (a grey cell, a cross), never as a value,
and say why (their status); a case that completed but whose metric has no value (a
``first_time`` whose condition never held) is drawn the same way, labelled ``no value``. Axes
and colour bars carry the targets' and metrics' units (:mod:`.study_units`).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import CHECK_PREFIX, StudyPlan
from fmionnx.core.owned import OwnedFolder
from fmionnx.results.plots import DPI, Drawing, save_figure
from fmionnx.results.study_units import labelled, plan_units

if TYPE_CHECKING:
    import pandas as pd

#: Inches per panel.
PANEL = (6.0, 4.5)


def new_figure_plain(ncols: int = 1) -> tuple[Any, Any]:
    """A matplotlib Figure (object API, no pyplot state) and its axes (one per column)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(PANEL[0] * ncols, PANEL[1]), dpi=DPI)
    return figure, figure.subplots(ncols=ncols)


def write_study_plots(table: pd.DataFrame, plan: StudyPlan, out: Path) -> list[Path]:
    """Write the study's summary plots into ``out``; returns their paths."""
    written = [draw() for draw in study_drawings(table, plan, out)]
    OwnedFolder(out).note(written)  # a later --force may delete them (fmionnx.core.owned)
    return written


def study_drawings(table: pd.DataFrame, plan: StudyPlan, out: Path) -> list[Drawing]:
    """The study's summary plots, in order, each drawn and written into ``out`` when called
    (a plot worker draws them side by side); the caller notes the files as the study's."""
    numeric = [t for t in plan.targets if _numeric(table[t])]
    if table.empty or not numeric:
        return []
    units = plan_units(plan)
    names = {name: labelled(name, unit) for name, unit in units.items()}
    found: list[Drawing] = []
    for metric in plan.plotted_metrics:  # at most PLOTTED_METRICS (W100 says so)
        draw = _heatmap if len(numeric) == 2 and _is_grid(table, numeric) else _against
        found.append(functools.partial(draw, table, numeric, metric.name, names, out))
    if plan.check_names:
        found.append(functools.partial(_passfail, table, numeric, plan, names, out))
    return found


#: What a case that completed without a value for a metric is labelled.
NO_VALUE = "no value"


def _numeric(column: pd.Series) -> bool:
    import pandas as pd

    return bool(pd.api.types.is_numeric_dtype(column)) and not bool(
        pd.api.types.is_bool_dtype(column)
    )


def _is_grid(table: pd.DataFrame, targets: list[str]) -> bool:
    return not table.duplicated(subset=targets).any()


def _file(prefix: str, name: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "metric"
    return f"{prefix}-{slug}.png"


def completed(table: pd.DataFrame, metric: str) -> pd.Series:
    """``metric`` where the case completed, NaN elsewhere: a fault's or a timeout's value is
    measured on what was recorded up to then, not on the run the study asked for."""
    return table[metric].where(table["status"] == "ok")


def _heatmap(
    table: pd.DataFrame, targets: list[str], metric: str, names: dict[str, str], out: Path
) -> Path:
    from matplotlib import colormaps

    shown = table.assign(**{metric: completed(table, metric)})
    grid = shown.pivot_table(
        index=targets[1], columns=targets[0], values=metric, aggfunc="mean", dropna=False
    )
    figure, axes = new_figure_plain()
    palette = colormaps["viridis"].with_extremes(bad="lightgrey")
    image = axes.imshow(grid.to_numpy(dtype=float), origin="lower", aspect="auto", cmap=palette)
    _ticks(axes, grid)
    axes.set_xlabel(names.get(targets[0], targets[0]))
    axes.set_ylabel(names.get(targets[1], targets[1]))
    axes.set_title(metric)
    figure.colorbar(image, ax=axes, label=names.get(metric, metric))
    low, high = image.get_clim()
    for (row, col), value in _cells(grid):
        bright = high > low and (value - low) / (high - low) > 0.6  # viridis is light up there
        colour = "black" if bright else "white"
        axes.text(col, row, f"{value:.3g}", ha="center", va="center", color=colour, fontsize=8)
    columns, rows = list(grid.columns), list(grid.index)
    for _, case in table[shown[metric].isna()].iterrows():  # the grey cells say why
        col, row = columns.index(case[targets[0]]), rows.index(case[targets[1]])
        why = NO_VALUE if case["status"] == "ok" else case["status"]
        axes.text(col, row, why, ha="center", va="center", color="tab:red", fontsize=8, gid=why)
    return save_figure(figure, out / _file("heatmap", metric))


def _cells(grid: pd.DataFrame) -> list[tuple[tuple[int, int], float]]:
    import math

    cells = []
    values = grid.to_numpy(dtype=float)
    for row in range(values.shape[0]):
        for col in range(values.shape[1]):
            if not math.isnan(values[row, col]):
                cells.append(((row, col), float(values[row, col])))
    return cells


def _ticks(axes: Any, grid: pd.DataFrame) -> None:
    axes.set_xticks(range(len(grid.columns)), [f"{v:g}" for v in grid.columns])
    axes.set_yticks(range(len(grid.index)), [f"{v:g}" for v in grid.index])


def _against(
    table: pd.DataFrame, targets: list[str], metric: str, names: dict[str, str], out: Path
) -> Path:
    figure, axes = new_figure_plain(ncols=len(targets))
    panels = axes if len(targets) > 1 else [axes]
    shown = table.assign(**{metric: completed(table, metric)})
    incomplete = table[table["status"] != "ok"]
    empty = table[(table["status"] == "ok") & shown[metric].isna()]
    for panel, target in zip(panels, targets, strict=True):
        ordered = shown.sort_values(target, kind="stable")
        style = "o-" if len(targets) == 1 else "o"
        panel.plot(ordered[target], ordered[metric], style)
        for cases, colour, label in (
            (incomplete, "tab:red", "did not complete"),
            (empty, "tab:grey", NO_VALUE),
        ):
            if not cases.empty:  # a cross at the panel's foot, where no value is drawn
                panel.plot(
                    cases[target], [0.03] * len(cases), "x", color=colour,
                    transform=panel.get_xaxis_transform(), label=label, gid=label,
                )  # fmt: skip
        if not incomplete.empty or not empty.empty:
            panel.legend(loc="best")
        panel.set_xlabel(names.get(target, target))
        panel.set_ylabel(names.get(metric, metric))
        panel.grid(visible=True, alpha=0.3)
    figure.suptitle(metric)
    return save_figure(figure, out / _file("metric", metric))


def _passfail(
    table: pd.DataFrame, targets: list[str], plan: StudyPlan, names: dict[str, str], out: Path
) -> Path:
    checks = [CHECK_PREFIX + n for n in plan.check_names]
    passed = (table["status"] == "ok") & table[checks].all(axis=1)
    figure, axes = new_figure_plain()
    x = table[targets[0]]
    y = table[targets[1]] if len(targets) > 1 else passed.astype(int)
    axes.scatter(x[passed], y[passed], c="tab:green", marker="o", s=80, label="passed")
    axes.scatter(x[~passed], y[~passed], c="tab:red", marker="x", s=80, label="failed")
    axes.set_xlabel(names.get(targets[0], targets[0]))
    if len(targets) > 1:
        axes.set_ylabel(names.get(targets[1], targets[1]))
    else:
        axes.set_yticks([0, 1], ["failed", "passed"])
    axes.set_title("checks: " + ", ".join(plan.check_names))
    axes.legend(loc="best")
    axes.grid(visible=True, alpha=0.3)
    return save_figure(figure, out / "passfail.png")
