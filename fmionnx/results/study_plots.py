"""Summary plots of a study (matplotlib, Agg): what a table of numbers hides at a glance.

* one target: each metric against it (``metric-<name>.png``);
* two targets: a heat map per metric over the grid (``heatmap-<name>.png``);
* more targets, or sampled ones: each metric against each target, as points;
* always, with checks: a pass/fail map (``passfail.png``) over the first two targets (or
  against the first one), green where the case ran and passed every check.

Cases that did not complete are drawn as missing (a grey cell, a cross), never as a value,
and say why (their status); a case that completed but whose metric has no value (a
``first_time`` whose condition never held) is drawn the same way, labelled ``no value``. Axes
and colour bars carry the targets' and metrics' units (:mod:`.study_units`). A target that is
no number (text, an array, booleans) has no axis: each figure names it in a note at its foot,
and a metric's points are joined by a line only when the study has one target, drawn or not.
"""

from __future__ import annotations

import functools
import math
import re
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import CHECK_PREFIX, StudyPlan
from fmionnx.core.owned import OwnedFolder
from fmionnx.results.plots import Drawing, blank_figure, save_figure
from fmionnx.results.study_units import labelled, plan_units

if TYPE_CHECKING:
    from fmionnx.results.casetable import CaseTable

#: Inches per panel.
PANEL = (6.0, 4.5)


def new_figure_plain(ncols: int = 1) -> tuple[Any, Any]:
    """A matplotlib Figure (object API, no pyplot state) and its axes (one per column)."""
    figure = blank_figure((PANEL[0] * ncols, PANEL[1]))
    return figure, figure.subplots(ncols=ncols)


def write_study_plots(table: CaseTable, plan: StudyPlan, out: Path) -> list[Path]:
    """Write the study's summary plots into ``out``; returns their paths."""
    written = [draw() for draw in study_drawings(table, plan, out)]
    OwnedFolder(out).note(written)  # a later --force may delete them (fmionnx.core.owned)
    return written


def study_drawings(table: CaseTable, plan: StudyPlan, out: Path) -> list[Drawing]:
    """The study's summary plots, in order, each drawn and written into ``out`` when called
    (a plot worker draws them side by side); the caller notes the files as the study's."""
    numeric = [t for t in plan.targets if table.kind(t) in NUMERIC]
    if table.empty or not numeric:
        return []
    units = plan_units(plan)
    names = {name: labelled(name, unit) for name, unit in units.items()}
    left_out = _left_out(table, plan, numeric)
    found: list[Drawing] = []
    for metric in plan.plotted_metrics:  # at most PLOTTED_METRICS (W100 says so)
        draw = _heatmap if len(numeric) == 2 and _is_grid(table, numeric) else _against
        found.append(
            functools.partial(draw, table, numeric, metric.name, names, out, left_out=left_out)
        )
    if plan.check_names:
        found.append(
            functools.partial(_passfail, table, numeric, plan, names, out, left_out=left_out)
        )
    return found


@dataclass(frozen=True)
class LeftOut:
    """The study's targets no axis shows (text, arrays, booleans): how many, and the note
    that names them under each figure."""

    count: int = 0
    note: str = ""

    def say(self, figure: Any) -> None:
        """Say under ``figure`` which targets it does not show, as a figure says what else it
        leaves out (a case without a value, an infinite value): a text or an array target
        was dropped without a word, its cases drawn as if they were repeats (a bug hunt)."""
        if self.note:  # in lines the figure's width holds (long target names make long ones)
            text = textwrap.fill(self.note, width=int(figure.get_figwidth() * CHARS_PER_INCH))
            figure.supxlabel(text, fontsize="small", color="tab:grey", gid=LEFT_OUT)


#: Every target drawn.
NOTHING = LeftOut()
#: What a case that completed without a value for a metric is labelled.
NO_VALUE = "no value"
#: The columns drawn on an axis: numbers (a column of booleans or text is not one).
NUMERIC = ("int", "uint", "float")

#: The ``gid`` of a figure's note on the targets it does not show.
LEFT_OUT = "targets not drawn"
#: How many targets a note names before it counts the rest.
NAMED = 4
#: Characters of the note (matplotlib's "small" font) that an inch of figure holds.
CHARS_PER_INCH = 15


def _left_out(table: CaseTable, plan: StudyPlan, numeric: list[str]) -> LeftOut:
    """The targets no axis shows, named (the first :data:`NAMED` of them)."""
    dropped = [t for t in plan.targets if t not in numeric]
    if not dropped:
        return NOTHING
    values = plan.cases[0].values() if plan.cases else {}
    named = [f"{t} ({_what(values.get(t), table.kind(t))})" for t in dropped[:NAMED]]
    rest = f" and {len(dropped) - NAMED} more" if len(dropped) > NAMED else ""
    note = "not drawn, not numbers: " + ", ".join(named) + rest + " (the table has them)"
    return LeftOut(len(dropped), note)


def _what(value: object, kind: str) -> str:
    """What a target that is not a number holds, in a word."""
    if isinstance(value, tuple):
        return "an array"
    if kind == "bool" or isinstance(value, bool):
        return "booleans"
    return "text" if kind == "text" else "mixed values"


def _is_grid(table: CaseTable, targets: list[str]) -> bool:
    points = list(zip(*(table.column(t) for t in targets), strict=True))
    return len(set(points)) == len(points)


def _file(prefix: str, name: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "metric"
    return f"{prefix}-{slug}.png"


def completed(table: CaseTable, metric: str) -> list[float]:
    """``metric`` where the case completed, NaN elsewhere: a fault's or a timeout's value is
    measured on what was recorded up to then, not on the run the study asked for."""
    statuses = table.column("status")
    values = table.column(metric)
    return [_float(v) if s == "ok" else math.nan for v, s in zip(values, statuses, strict=True)]


def _float(value: Any) -> float:
    return math.nan if value is None else float(value)


def _numbers(table: CaseTable, name: str) -> list[float]:
    """A column of numbers as floats (an integer among floats is one, as in the table)."""
    return [_float(v) for v in table.column(name)]


def _inf(value: float) -> str:
    """How a plot labels an infinite metric (as the case's record writes it)."""
    return "inf" if value > 0 else "-inf"


def _heatmap(
    table: CaseTable,
    targets: list[str],
    metric: str,
    names: dict[str, str],
    out: Path,
    *,
    left_out: LeftOut = NOTHING,
) -> Path:
    import numpy as np
    from matplotlib import colormaps

    shown = completed(table, metric)
    xs, ys = table.column(targets[0]), table.column(targets[1])
    columns, rows = sorted(set(xs)), sorted(set(ys))
    grid = np.full((len(rows), len(columns)), np.nan)
    for x, y, value in zip(xs, ys, shown, strict=True):  # an infinity has no colour: grey
        grid[rows.index(y), columns.index(x)] = value if not math.isinf(value) else np.nan
    figure, axes = new_figure_plain()
    palette = colormaps["viridis"].with_extremes(bad="lightgrey")
    image = axes.imshow(grid, origin="lower", aspect="auto", cmap=palette)
    axes.set_xticks(range(len(columns)), [f"{v:g}" for v in columns])
    axes.set_yticks(range(len(rows)), [f"{v:g}" for v in rows])
    axes.set_xlabel(names.get(targets[0], targets[0]))
    axes.set_ylabel(names.get(targets[1], targets[1]))
    axes.set_title(metric)
    figure.colorbar(image, ax=axes, label=names.get(metric, metric))
    low, high = image.get_clim()
    for (row, col), value in np.ndenumerate(grid):
        if math.isnan(value):
            continue
        bright = high > low and (value - low) / (high - low) > 0.6  # viridis is light up there
        colour = "black" if bright else "white"
        axes.text(col, row, f"{value:.3g}", ha="center", va="center", color=colour, fontsize=8)
    statuses = table.column("status")
    for x, y, value, status in zip(xs, ys, shown, statuses, strict=True):
        if math.isnan(value) or math.isinf(value):  # the grey cells say why
            why = (NO_VALUE if status == "ok" else status) if math.isnan(value) else _inf(value)
            col, row = columns.index(x), rows.index(y)
            axes.text(col, row, why, ha="center", va="center", color="tab:red", fontsize=8, gid=why)
    left_out.say(figure)
    return save_figure(figure, out / _file("heatmap", metric))


def _against(
    table: CaseTable,
    targets: list[str],
    metric: str,
    names: dict[str, str],
    out: Path,
    *,
    left_out: LeftOut = NOTHING,
) -> Path:
    figure, axes = new_figure_plain(ncols=len(targets))
    panels = axes if len(targets) > 1 else [axes]
    shown = completed(table, metric)
    statuses = table.column("status")
    incomplete = [i for i, s in enumerate(statuses) if s != "ok"]
    empty = [i for i, s in enumerate(statuses) if s == "ok" and math.isnan(shown[i])]
    # Infinities are values (a record keeps them), but a line cannot reach them: a triangle
    # at the panel's top or foot marks each (matplotlib left them out unmarked).
    above = [i for i, v in enumerate(shown) if v == math.inf]
    below = [i for i, v in enumerate(shown) if v == -math.inf]
    finite = [v if not math.isinf(v) else math.nan for v in shown]
    for panel, target in zip(panels, targets, strict=True):
        xs = _numbers(table, target)
        order = sorted(range(len(xs)), key=xs.__getitem__)  # stable: ties in case order
        # A line joins cases that differ in this target alone: only when the study has no
        # other target, drawn or not (a text target's cases zigzagged along one line).
        style = "o-" if len(targets) + left_out.count == 1 else "o"
        panel.plot([xs[i] for i in order], [finite[i] for i in order], style)
        for cases, marker, height, colour, label in (
            (incomplete, "x", 0.03, "tab:red", "did not complete"),
            (empty, "x", 0.03, "tab:grey", NO_VALUE),
            (above, "^", 0.97, "tab:purple", _inf(math.inf)),
            (below, "v", 0.03, "tab:purple", _inf(-math.inf)),
        ):
            if cases:  # a mark at the panel's edge, where no value is drawn
                panel.plot(
                    [xs[i] for i in cases], [height] * len(cases), marker, color=colour,
                    transform=panel.get_xaxis_transform(), label=label, gid=label,
                )  # fmt: skip
        if incomplete or empty or above or below:
            panel.legend(loc="best")
        panel.set_xlabel(names.get(target, target))
        panel.set_ylabel(names.get(metric, metric))
        panel.grid(visible=True, alpha=0.3)
    figure.suptitle(metric)
    left_out.say(figure)
    return save_figure(figure, out / _file("metric", metric))


def _passfail(
    table: CaseTable,
    targets: list[str],
    plan: StudyPlan,
    names: dict[str, str],
    out: Path,
    *,
    left_out: LeftOut = NOTHING,
) -> Path:
    checks = [table.column(CHECK_PREFIX + n) for n in plan.check_names]
    statuses = table.column("status")
    passed = [
        status == "ok" and all(bool(c[i]) for c in checks) for i, status in enumerate(statuses)
    ]
    figure, axes = new_figure_plain()
    x = _numbers(table, targets[0])
    y = _numbers(table, targets[1]) if len(targets) > 1 else [int(p) for p in passed]
    for wanted, colour, marker, label in ((True, "tab:green", "o", "passed"),
                                          (False, "tab:red", "x", "failed")):  # fmt: skip
        chosen = [i for i, p in enumerate(passed) if p is wanted]
        axes.scatter(
            [x[i] for i in chosen], [y[i] for i in chosen],
            c=colour, marker=marker, s=80, label=label,
        )  # fmt: skip
    axes.set_xlabel(names.get(targets[0], targets[0]))
    if len(targets) > 1:
        axes.set_ylabel(names.get(targets[1], targets[1]))
    else:
        axes.set_yticks([0, 1], ["failed", "passed"])
    axes.set_title("checks: " + ", ".join(plan.check_names))
    axes.legend(loc="best")
    axes.grid(visible=True, alpha=0.3)
    left_out.say(figure)
    return save_figure(figure, out / "passfail.png")
