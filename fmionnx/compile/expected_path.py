"""A component's expected path: the polyline ``<model stem>.path.csv`` next to its model.

Plots draw it (``over: world.expected_path``) and checks measure the deviation from it
(``deviation(x, y, from=world.expected_path)``); both find it by this one rule. The file has
a header line naming at least the columns ``x`` and ``y``, then one point per line.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

#: The reference a system file writes after a component's name: ``world.expected_path``.
EXPECTED_PATH = "expected_path"
#: Most points a path file may hold (it is read at compile time and kept in the system).
MAX_POINTS = 100_000


class PathFileError(ValueError):
    """A path file that cannot be read as a polyline; the message names the line."""


def expected_path_file(model: Path) -> Path:
    """Where the expected path of the model at ``model`` is: ``<stem>.path.csv`` beside it."""
    return model.with_name(model.stem + ".path.csv")


def read_expected_path(path: Path) -> tuple[tuple[float, float], ...]:
    """The points of a path file, in order; PathFileError says what is wrong and where."""
    try:
        with path.open(encoding="utf-8", newline="") as stream:
            rows = csv.reader(stream)
            header = [h.strip() for h in next(rows, [])]
            if "x" not in header or "y" not in header:
                msg = f"`{path.name}`:1: the header must name the columns `x` and `y`"
                raise PathFileError(msg)
            x, y = header.index("x"), header.index("y")
            points: list[tuple[float, float]] = []
            for row in rows:
                if not any(cell.strip() for cell in row):
                    continue
                line = rows.line_num
                if len(points) == MAX_POINTS:
                    msg = f"`{path.name}`:{line}: more than {MAX_POINTS} points"
                    raise PathFileError(msg)
                points.append((_number(row, x, path, line), _number(row, y, path, line)))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        msg = f"`{path.name}` cannot be read: {exc}"
        raise PathFileError(msg) from None
    if len(points) < 2:
        msg = f"`{path.name}` holds {len(points)} point(s); a path needs at least 2"
        raise PathFileError(msg)
    return tuple(points)


def _number(row: list[str], column: int, path: Path, line: int) -> float:
    try:
        value = float(row[column])
    except (IndexError, ValueError):
        shown = row[column].strip() if column < len(row) else ""
        msg = f"`{path.name}`:{line}: `{shown}` is not a number"
        raise PathFileError(msg) from None
    if not math.isfinite(value):
        msg = f"`{path.name}`:{line}: `{row[column].strip()}` is not a finite number"
        raise PathFileError(msg)
    return value
