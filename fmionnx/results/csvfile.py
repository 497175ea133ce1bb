"""``results.csv``: ``time`` then one column per recorded signal, at every base step.

Numbers are written with 17 significant digits, which round-trips every float64 exactly, so
two identical runs give byte-identical files and a reader gets back the very values computed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fmionnx.core.safewrite import atomic_text
from fmionnx.runtime.result import RunResult


def write_csv(result: RunResult, path: Path, *, aliases: dict[str, str] | None = None) -> Path:
    """Write the table; ``aliases`` renames columns (single-FMU runs use variable names)."""
    names = list(result.signals)
    header = ["time", *((aliases or {}).get(n, n) for n in names)]
    columns = [result.time, *(result.signals[n] for n in names)]
    table = np.column_stack(columns) if columns else np.zeros((0, 1))
    with atomic_text(path) as stream:  # never half-written, never through a planted link
        stream.write(",".join(_quote(h) for h in header) + "\n")
        np.savetxt(stream, table, fmt="%.17g", delimiter=",")
    return path


def _quote(name: str) -> str:
    return f'"{name}"' if "," in name or '"' in name else name


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a results.csv back into columns (for tests and plots of earlier runs)."""
    with path.open(encoding="utf-8") as stream:
        header = stream.readline().strip().split(",")
        data = np.loadtxt(stream, delimiter=",", ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}
