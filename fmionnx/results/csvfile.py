"""``results.csv``: ``time`` then one column per recorded signal, at every base step.

Every number is written as the shortest decimal that reads back as the very same float64
(Python's ``repr``, with the ``.0`` of a whole number dropped): ``0.004``, not the 17 digits
``0.0040000000000000001`` that also round-trip but read as noise. Two identical runs give
byte-identical files, and a reader gets back exactly the values computed. The in-process and
the ROS 2 backend both write through :func:`write_csv`, so their files compare byte for byte.
"""

from __future__ import annotations

from pathlib import Path
from typing import IO

import numpy as np
import numpy.typing as npt

from fmionnx.core.safewrite import atomic_text
from fmionnx.runtime.result import RunResult

#: Rows formatted at a time: bounds the formatting's memory (text and index arrays of a few
#: megabytes per column) however long the run.
BLOCK_ROWS = 32_768


def write_csv(result: RunResult, path: Path, *, aliases: dict[str, str] | None = None) -> Path:
    """Write the table; ``aliases`` renames columns (single-FMU runs use variable names)."""
    names = list(result.signals)
    header = ["time", *((aliases or {}).get(n, n) for n in names)]
    columns = [result.time, *(result.signals[n] for n in names)]
    table = np.column_stack(columns) if columns else np.zeros((0, 1))
    with atomic_text(path) as stream:  # never half-written, never through a planted link
        stream.write(",".join(_quote(h) for h in header) + "\n")
        write_rows(stream, table)
    return path


def write_rows(stream: IO[str], table: npt.NDArray[np.float64]) -> None:
    """Write ``table`` as CSV lines, every number as its shortest round-tripping decimal.

    Formatting a float that way (``repr``) costs more than ``%.17g``, but held outputs repeat
    the same value for many base steps: each distinct bit pattern of a block is formatted
    once and the cells are looked up, which makes the whole faster than ``numpy.savetxt``.
    Bit patterns, not values, are compared, so ``-0.0`` stays ``-0``.
    """
    bits = np.ascontiguousarray(table, dtype=np.float64).view(np.uint64)
    for first in range(0, len(bits), BLOCK_ROWS):
        block = bits[first : first + BLOCK_ROWS]
        distinct, where = np.unique(block, return_inverse=True)
        texts = np.array(
            [shortest_decimal(v) for v in distinct.view(np.float64).tolist()], dtype=object
        )
        cells = texts[where.reshape(block.shape)].tolist()
        stream.write("".join([",".join(row) + "\n" for row in cells]))


def shortest_decimal(value: float) -> str:
    """The shortest text that reads back as ``value`` (``0.004``, ``1``, ``1e-05``, ``nan``)."""
    return repr(value).removesuffix(".0")


def _quote(name: str) -> str:
    return f'"{name}"' if "," in name or '"' in name else name


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a results.csv back into columns (for tests and plots of earlier runs)."""
    with path.open(encoding="utf-8") as stream:
        header = stream.readline().strip().split(",")
        data = np.loadtxt(stream, delimiter=",", ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}
