"""What every view draws of the robot's course: the map plot's columns and the path so far.

The course is the compiled system's first xy plot (:func:`fmionnx.results.channels.map_plot`):
its two columns are the position, its scene (read at compile time, plain numbers) the map,
its expected path the line to follow, exactly as ``trajectory.png`` draws them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from fmionnx.results.channels import map_plot, trajectory_stride

if TYPE_CHECKING:
    from fmionnx.compile.ir import CompiledSystem, Plot
    from fmionnx.pipeline.observers import Rows


class Course:
    """The map plot of a system and the path travelled so far (thinned)."""

    def __init__(self, system: CompiledSystem) -> None:
        self.plot: Plot | None = map_plot(system)
        run = system.run
        self._spacing = trajectory_stride(run.step) * run.step
        self._next = run.start
        self.xs: list[float] = []
        self.ys: list[float] = []
        columns = self.plot.series if self.plot is not None else ()
        self.x = columns[0].columns[0] if columns else None
        self.y = columns[1].columns[0] if columns else None

    def add(self, rows: Rows) -> bool:
        """Take the path's points from ``rows`` (one per trajectory spacing); whether any."""
        if self.x is None or self.y is None:
            return False
        xs, ys = rows.columns.get(self.x), rows.columns.get(self.y)
        if xs is None or ys is None:
            return False
        added = False
        for i, time in enumerate(rows.time):
            if time + 1e-12 >= self._next:
                self.xs.append(float(xs[i]))
                self.ys.append(float(ys[i]))
                self._next = float(time) + self._spacing
                added = True
        return added

    def points(self) -> npt.NDArray[np.float64]:
        """The path so far as an ``(n, 2)`` array (non-finite points left out)."""
        path = np.column_stack([self.xs, self.ys]) if self.xs else np.zeros((0, 2))
        return path[np.isfinite(path).all(axis=1)]
