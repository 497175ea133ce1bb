"""Plots a system file asks for, drawn with matplotlib's Agg backend (no display needed).

``xy`` plots draw one signal against another (a trajectory, like the paper's Figure 16/17);
``over: world.expected_path`` draws the reference path underneath: the file
``<scene stem>.path.csv`` (columns ``x,y``) next to the MuJoCo scene of component ``world``.
``y`` plots draw signals over time.
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem, Plot, plot_file_problem
from fmionnx.core.safewrite import write_bytes_atomic
from fmionnx.runtime.result import RunResult


def read_path(path: Path) -> npt.NDArray[np.float64]:
    """An ``x,y`` path file as an ``(n, 2)`` array (header line required)."""
    with path.open(encoding="utf-8") as stream:
        header = [h.strip() for h in stream.readline().split(",")]
        data = np.loadtxt(stream, delimiter=",", ndmin=2)
    return np.asarray(data[:, [header.index("x"), header.index("y")]], dtype=np.float64)


def signal_column(text: str) -> str:
    """The results column of a signal reference (``a.b[1,2]`` keeps its flat index form)."""
    return re.sub(r"\s+", "", text)


def _file_name(index: int, plot: Plot, signals: list[str]) -> str:
    """``file`` when given; ``trajectory.png`` for an xy plot over a path; else derived.

    A ``file`` that is not a plain name (only a hand-edited compiled system can carry one: the
    compiler refuses it, E045) is ignored for the derived name, so nothing is written outside
    the output folder.
    """
    if plot.file and plot_file_problem(plot.file) is None:
        given = str(plot.file)
        return given if given.endswith((".png", ".svg", ".pdf")) else given + ".png"
    if plot.xy is not None and plot.reference is not None:
        stem = "trajectory" if index == 0 else f"trajectory{index}"
    elif plot.xy is not None:
        stem = f"{signals[1]}_vs_{signals[0]}"
    else:
        stem = f"plot{index}"
    return re.sub(r"[^\w.\[\]-]+", "_", stem) + ".png"


def write_plots(result: RunResult, system: CompiledSystem, out: Path) -> list[Path]:
    """Draw every plot of ``system``; a signal that was not recorded is skipped with a note."""
    if not system.plots:
        return []
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for index, plot in enumerate(system.plots):
        figure, axes = plt.subplots(figsize=(7, 6) if plot.xy else (9, 4.5))
        try:
            if plot.xy is not None:
                _xy(axes, result, plot)
                signals = list(plot.xy)
            else:
                signals = list(plot.y)
                _over_time(axes, result, signals)
            if plot.title:
                axes.set_title(plot.title)
            path = out / _file_name(index, plot, signals)
            figure.tight_layout()
            image = io.BytesIO()  # drawn in memory, then written atomically (no planted link)
            figure.savefig(image, dpi=120, format=path.suffix.lstrip(".") or "png")
            write_bytes_atomic(path, image.getvalue())
            written.append(path)
        finally:
            plt.close(figure)
    return written


def _xy(axes: Any, result: RunResult, plot: Plot) -> None:
    assert plot.xy is not None
    x_name, y_name = (signal_column(s) for s in plot.xy)
    if plot.reference is not None and plot.reference.is_file():
        path = read_path(plot.reference)
        axes.plot(path[:, 0], path[:, 1], "--", color="goldenrod", lw=2, label="expected path")
    if x_name in result.signals and y_name in result.signals:
        x, y = result.signals[x_name], result.signals[y_name]
        axes.plot(x, y, color="tab:blue", lw=1.5, label="simulated")
        axes.plot(x[:1], y[:1], "o", color="tab:green", label="start")
        axes.plot(x[-1:], y[-1:], "s", color="tab:red", label="end")
    axes.set_xlabel(x_name)
    axes.set_ylabel(y_name)
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(visible=True, alpha=0.3)
    axes.legend(loc="best")


def _over_time(axes: Any, result: RunResult, signals: list[str]) -> None:
    for text in signals:
        name = signal_column(text)
        if name in result.signals:
            axes.plot(result.time, result.signals[name], label=name)
    axes.set_xlabel("time [s]")
    axes.grid(visible=True, alpha=0.3)
    axes.legend(loc="best")
