"""``fmionnx run --plot``: every recorded signal over time, for any run, a lone FMU included.

A system file's ``plots:`` say what someone chose to look at; ``--plot`` is the first look at
a run nobody has written plots for yet. One panel per recorded port (an array's elements are
lines of one panel), labelled with the port and its declared unit, stacked over a shared time
axis: ``signals.png``, continued in ``signals-2.png``, ... when there are more than
:data:`PANELS_PER_FIGURE` ports, so that no panel becomes too flat to read.

Which port a results column belongs to comes from the compiled system: the columns each port
fills (:func:`fmionnx.core.signals.column_names`), under the names results use (a lone FMU's
columns are its variable names, ``aliases``).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from fmionnx.compile.ir import CompiledSystem, Series
from fmionnx.compile.plotfiles import SIGNALS_FILE, unique_name
from fmionnx.core.signals import column_names
from fmionnx.results.plots import (
    PANEL_HEIGHT,
    TIME_WIDTH,
    Drawing,
    blank_figure,
    draw_panel,
    save_figure,
)
from fmionnx.runtime.result import RunResult

#: Most panels one figure holds; more ports continue in the next file.
PANELS_PER_FIGURE = 10


def signal_series(
    result: RunResult, system: CompiledSystem, aliases: Mapping[str, str] | None = None
) -> list[Series]:
    """The recorded signals as one series per port, in the order of the results columns."""
    aliases = aliases or {}
    owner: dict[str, tuple[str, str | None]] = {}  # column -> (port label, unit)
    for component in system.components:
        for port in component.interface.ports:
            label = port.name if aliases else f"{component.name}.{port.name}"
            for column in column_names(component.name, port):
                owner[aliases.get(column, column)] = (label, port.unit)
    grouped: dict[tuple[str, str | None], list[str]] = {}
    for column in result.signals:
        key = owner.get(column, (column, None))
        grouped.setdefault(key, []).append(column)
    return [Series(label, tuple(columns), unit) for (label, unit), columns in grouped.items()]


def write_signals_plot(
    result: RunResult,
    system: CompiledSystem,
    out: Path,
    *,
    aliases: Mapping[str, str] | None = None,
    taken: set[str] | None = None,
) -> list[Path]:
    """Draw every recorded signal into ``signals.png`` (and more pages when needed).

    ``taken`` holds the names other files of the run use (a system plot called
    ``signals.png``): those are skipped (``signals-2.png`` ...). A run that recorded nothing
    writes nothing.
    """
    drawings = signals_drawings(result, system, out, aliases=aliases, taken=taken)
    return [draw() for draw in drawings]


def signals_drawings(
    result: RunResult,
    system: CompiledSystem,
    out: Path,
    *,
    aliases: Mapping[str, str] | None = None,
    taken: set[str] | None = None,
) -> list[Drawing]:
    """:func:`write_signals_plot`'s pages as drawings, in order, each drawn and written when
    called (the plot worker hands them to several processes)."""
    series = signal_series(result, system, aliases)
    names = set(taken or ())
    drawings: list[Drawing] = []
    stem = SIGNALS_FILE.removesuffix(".png")
    title = f"{system.name}: recorded signals"
    for start in range(0, len(series), PANELS_PER_FIGURE):
        page = series[start : start + PANELS_PER_FIGURE]
        if start == 0 and SIGNALS_FILE not in names:
            name = SIGNALS_FILE
            names.add(name)
        else:
            name = unique_name(stem, names)  # never SIGNALS_FILE itself: it is reserved
        drawings.append(functools.partial(_write_page, page, result, title, out / name))
    return drawings


def _write_page(page: list[Series], result: RunResult, title: str, path: Path) -> Path:
    return save_figure(draw_signals(page, result, title=title), path)


def draw_signals(series: list[Series], result: RunResult, *, title: str) -> Any:
    """A Figure with one panel per series over a shared time axis."""
    figure = blank_figure((TIME_WIDTH, 1.4 + PANEL_HEIGHT * 0.8 * len(series)))
    panels = figure.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
    for axes, item in zip(panels, series, strict=True):
        draw_panel(axes, result, [item], item.unit)
    panels[-1].set_xlabel("time [s]")
    panels[0].set_title(title)
    return figure
