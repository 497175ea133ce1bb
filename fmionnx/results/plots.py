"""The plots a system file asks for, drawn from the compiled system and the recorded signals.

Everything a plot needs was resolved at compile time (:class:`~fmionnx.compile.ir.Plot`):
the results columns and unit of every signal, the expected path's points, the map of the
scene, the file name. Drawing reads no model file and knows no component kind.

* An ``xy`` plot draws one signal against the other over the scene's map (shapes in their
  colours, sites named, the landmarks the scene labels in the legend) and the expected path,
  with axes labelled ``odometry.posX [m]``, and marks the time along the run (a dot and its
  time every round number of seconds).
* A ``y`` plot draws signals over time, one panel per unit (a panel's y axis has one unit),
  each labelled with its signals and unit; its ``marks`` put a labelled line wherever a
  discrete signal (a controller's state) changes.

Figures are made with matplotlib's object API (no pyplot state, no display) and written
atomically inside the output folder. A signal that was not recorded in this run (the Python
API can choose what to record) is named on the figure and logged, never silently missing.
"""

from __future__ import annotations

import functools
import io
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fmionnx.compile.ir import CompiledSystem, Marks, Plot, Series, plot_file_problem
from fmionnx.compile.plotfiles import derived_stem, unique_name, with_suffix
from fmionnx.core.safewrite import write_bytes_atomic
from fmionnx.results.scenedraw import SITE_LAYER, draw_scene
from fmionnx.runtime.result import RunResult

LOG = logging.getLogger("fmionnx.results")
#: Inches: an xy plot is about square, a time plot wide; each extra panel adds height.
XY_SIZE = (7.0, 6.5)
TIME_WIDTH, PANEL_HEIGHT = 9.0, 2.6
DPI = 120
#: A figure to draw: draws it and writes its file when called, returns the file.
Drawing = Callable[[], Path]
#: Most time marks along a trajectory (dots every 1, 2 or 5 times a power of ten seconds).
MOST_TIME_MARKS = 8


def write_plots(result: RunResult, system: CompiledSystem, out: Path) -> list[Path]:
    """Draw every plot of ``system`` into ``out``; returns the files written."""
    return [draw() for draw in plot_drawings(result, system, out)]


def plot_drawings(result: RunResult, system: CompiledSystem, out: Path) -> list[Drawing]:
    """One drawing per plot of ``system``, in order: each draws its figure and writes its
    file into ``out`` when called (the plot worker hands them to several processes)."""
    return [
        functools.partial(_write_plot, plot, result, out / name)
        for plot, name in zip(system.plots, plot_file_names(system.plots), strict=True)
    ]


def _write_plot(plot: Plot, result: RunResult, path: Path) -> Path:
    figure = new_figure(plot)
    draw_plot(figure, plot, result)
    return save_figure(figure, path)


def plot_file_names(plots: tuple[Plot, ...]) -> list[str]:
    """Each plot's file name: the compiled one, made plain and unique once more.

    The compiler has settled the names; a hand-edited compiled system may still carry one
    that is not a plain name (it is replaced by a derived one, so nothing is written outside
    the output folder) or the same name twice (the second gets ``-2``).
    """
    taken: set[str] = set()
    names = []
    for plot in plots:
        if plot.file and plot_file_problem(plot.file) is None:
            name = with_suffix(plot.file)
            if name not in taken:
                taken.add(name)
                names.append(name)
                continue
            stem, _, suffix = name.rpartition(".")
            names.append(unique_name(stem, taken, "." + suffix))
            continue
        stem = derived_stem(plot.title, plot.xy, plot.y, over=bool(plot.path or plot.scene))
        names.append(unique_name(stem, taken))
    return names


def new_figure(plot: Plot) -> Any:
    """An empty matplotlib Figure sized for ``plot``."""
    if plot.xy is not None:
        return blank_figure(XY_SIZE)
    panels = len(unit_groups(series_of(plot)))
    return blank_figure((TIME_WIDTH, 1.4 + PANEL_HEIGHT * max(panels, 1)))


#: matplotlib settings that give a new figure a layout engine (a user's ``matplotlibrc`` may
#: set them): :func:`save_figure` lays each figure out itself.
LAYOUT_SETTINGS: tuple[Any, ...] = ("figure.autolayout", "figure.constrained_layout.use")
#: A figure's layout engine at its creation: none (matplotlib takes ``"none"`` there, though
#: its type hints leave it out).
NO_ENGINE: Any = "none"


def blank_figure(size: tuple[float, float]) -> Any:
    """An empty matplotlib Figure (object API, no pyplot state) of ``size`` inches.

    Without a layout engine whatever the user's matplotlib settings: with constrained layout
    turned on there, ``tight_layout`` refused a figure holding a colour bar (a heat map), and
    the plot was not drawn."""
    from matplotlib.figure import Figure

    return Figure(figsize=size, dpi=DPI, layout=NO_ENGINE)


def save_figure(figure: Any, path: Path) -> Path:
    """Write ``figure`` to ``path`` (format from the suffix), atomically: drawn in memory, then
    renamed into place, so a link planted at the name is replaced, not written through."""
    import matplotlib

    figure.tight_layout()
    # tight_layout leaves a placeholder layout engine, and with any engine set savefig lays
    # the whole figure out once more before it draws (a draw without rendering: a third of
    # a figure's time here). The layout is done: nothing is left for an engine to do. (With
    # a layout setting on, "no engine" would mean that engine: the placeholder stays.)
    if not any(matplotlib.rcParams[name] for name in LAYOUT_SETTINGS):
        figure.set_layout_engine(None)
    image = io.BytesIO()
    figure.savefig(image, format=path.suffix.lstrip(".") or "png")
    write_bytes_atomic(path, image.getvalue())
    return path


def draw_plot(figure: Any, plot: Plot, result: RunResult) -> None:
    """Draw ``plot`` of ``result`` on an empty ``figure``."""
    if plot.xy is not None:
        axes = figure.subplots()
        draw_xy(axes, plot, result)
        if plot.title:
            axes.set_title(plot.title)
    else:
        draw_over_time(figure, plot, result)


def series_of(plot: Plot) -> tuple[Series, ...]:
    """The plot's resolved series; for a compiled system without them (made by hand), each
    signal as its own column, without a unit."""
    if plot.series:
        return plot.series
    return tuple(Series(s, (s,)) for s in (plot.xy or plot.y))


def draw_xy(axes: Any, plot: Plot, result: RunResult) -> None:
    """A trajectory: y against x over the scene's map and the expected path."""
    if plot.scene is not None:
        draw_scene(axes, plot.scene)
    if plot.path:
        xs, ys = zip(*plot.path, strict=True)
        axes.plot(xs, ys, "--", color="goldenrod", lw=2, label="expected path", zorder=2)
    series = series_of(plot)
    x_axis, y_axis = (series[0], series[1]) if len(series) == 2 else (None, None)
    missing = [s for s in series if not _present(s, result)]
    if x_axis is not None and y_axis is not None and not missing:
        x, y = result.signals[x_axis.columns[0]], result.signals[y_axis.columns[0]]
        axes.plot(x, y, color="tab:blue", lw=1.5, label="simulated", zorder=3)
        _time_marks(axes, result.time, x, y)
        # start and end above the sites' markers: a run starts at A, inside its circle
        axes.plot(x[:1], y[:1], "o", color="tab:green", label="start", zorder=SITE_LAYER + 1)
        axes.plot(x[-1:], y[-1:], "s", color="tab:red", label="end", zorder=SITE_LAYER + 1)
    _note_missing(axes, missing)
    axes.set_xlabel(x_axis.label if x_axis is not None else (plot.xy or ("x", "y"))[0])
    axes.set_ylabel(y_axis.label if y_axis is not None else (plot.xy or ("x", "y"))[1])
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(visible=True, alpha=0.3)
    if axes.get_legend_handles_labels()[0]:
        axes.legend(loc="best")


def time_step(duration: float, most: int = MOST_TIME_MARKS) -> float:
    """A round interval (1, 2, 5 times a power of ten, seconds) giving at most ``most`` marks."""
    import math

    if not duration > 0:
        return 0.0
    decade = 10.0 ** math.floor(math.log10(duration / most))
    for factor in (1.0, 2.0, 5.0, 10.0):
        if duration / (factor * decade) <= most:
            return factor * decade
    return 10.0 * decade


def _time_marks(axes: Any, time: Any, x: Any, y: Any) -> None:
    """Dots along the path every round number of seconds, each labelled with its time."""
    import numpy as np

    if len(time) < 2:
        return
    step = time_step(float(time[-1] - time[0]))
    if step <= 0:
        return
    first = np.ceil(time[0] / step) * step
    marks = np.arange(first if first > time[0] else first + step, time[-1], step)
    rows = np.searchsorted(time, marks - 1e-9 * step)
    if not len(rows):
        return
    axes.plot(
        x[rows], y[rows], ".", color="tab:blue", markersize=7, zorder=3.5,
        label=f"every {step:g} s", gid="time marks",
    )  # fmt: skip
    for row, t in zip(rows, marks, strict=True):
        axes.annotate(
            f"{t:g} s", (x[row], y[row]), xytext=(4, -10), textcoords="offset points",
            fontsize=7, color="tab:blue", zorder=3.5, gid="time marks",
        )  # fmt: skip


def unit_groups(series: tuple[Series, ...]) -> list[tuple[str | None, list[Series]]]:
    """Series grouped by unit, in order of first appearance (one panel each)."""
    groups: dict[str | None, list[Series]] = {}
    for item in series:
        groups.setdefault(item.unit, []).append(item)
    return list(groups.items())


def draw_over_time(figure: Any, plot: Plot, result: RunResult) -> None:
    """Signals over time: one panel per unit, stacked, sharing the time axis."""
    groups = unit_groups(series_of(plot))
    panels = figure.subplots(max(len(groups), 1), 1, sharex=True, squeeze=False)[:, 0]
    for axes, (unit, members) in zip(panels, groups, strict=False):
        draw_panel(axes, result, members, unit)
    panels[-1].set_xlabel("time [s]")
    if plot.title:
        panels[0].set_title(plot.title)
    if plot.marks is not None:
        draw_marks(panels, plot.marks, result)


def draw_marks(panels: Any, marks: Marks, result: RunResult) -> None:
    """A dotted line on every panel where ``marks``' signal changes, labelled on the top one."""
    import numpy as np

    values = result.signals.get(marks.column)
    if values is None:
        _note_missing(panels[0], [Series(marks.signal, (marks.column,))])
        return
    changes = np.flatnonzero(values[1:] != values[:-1]) + 1
    for row in changes:
        t = float(result.time[row])
        for axes in panels:
            axes.axvline(t, color="grey", lw=0.8, ls=":", zorder=0, gid="marks")
        panels[0].annotate(
            marks.label(float(values[row])), (t, 1.0), xycoords=("data", "axes fraction"),
            xytext=(2, -2), textcoords="offset points", rotation=90, va="top", ha="left",
            fontsize=7, color="dimgrey", gid="marks",
        )  # fmt: skip


def draw_panel(axes: Any, result: RunResult, members: list[Series], unit: str | None) -> None:
    """One panel: every column of ``members`` over time, the y axis named by them and
    ``unit``; a legend when it holds more than one line."""
    missing = []
    lines = 0
    for item in members:
        present = [c for c in item.columns if c in result.signals]
        if not present:
            missing.append(item)
            continue
        for column in present:
            label = item.label if len(item.columns) == 1 else _element_label(item, column)
            axes.plot(result.time, result.signals[column], label=label)
            lines += 1
    _note_missing(axes, missing)
    names = ", ".join(item.signal for item in members)
    axes.set_ylabel(f"{names} [{unit}]" if unit else names)
    axes.grid(visible=True, alpha=0.3)
    if lines > 1:
        axes.legend(loc="best", fontsize="small")


def _element_label(item: Series, column: str) -> str:
    """``detector.blobX[0,2] [px]``: one element's line of an array signal."""
    element = column[column.rfind("[") :] if column.endswith("]") else ""
    return f"{item.signal}{element} [{item.unit}]" if item.unit else f"{item.signal}{element}"


def _present(item: Series, result: RunResult) -> bool:
    return bool(item.columns) and all(c in result.signals for c in item.columns)


def _note_missing(axes: Any, missing: list[Series]) -> None:
    """Name the signals this run did not record, on the figure and in the log."""
    if not missing:
        return
    names = ", ".join(f"`{item.signal}`" for item in missing)
    LOG.warning("plot: %s not recorded in this run; drawn without it", names)
    axes.text(
        0.5,
        0.5,
        f"not recorded in this run: {names}",
        transform=axes.transAxes,
        ha="center",
        va="center",
        color="tab:red",
        gid="not recorded",
    )
