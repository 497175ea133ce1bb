"""``results.csv``: ``time`` then one column per recorded signal, at every base step.

Every number is written as the shortest decimal that reads back as the very same float64
(Python's ``repr``, with the ``.0`` of a whole number dropped): ``0.004``, not the 17 digits
``0.0040000000000000001`` that also round-trip but read as noise. Two identical runs give
byte-identical files, and a reader gets back exactly the values computed. The in-process and
the ROS 2 backend both write through :func:`write_csv`, so their files compare byte for byte.

A column of integers (an int64 or uint64 port: :mod:`fmionnx.runtime.recorder` records them
exactly) is written as whole numbers, digit for digit: float64 would round ``2**53 + 1``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fmionnx.core.safewrite import atomic_text
from fmionnx.runtime.result import RunResult

if TYPE_CHECKING:
    from fmionnx.results.csvahead import CsvAhead

#: Rows formatted at a time: bounds the formatting's memory (text and index arrays of a few
#: megabytes per column) however long the run.
BLOCK_ROWS = 32_768


def write_csv(
    result: RunResult,
    path: Path,
    *,
    aliases: dict[str, str] | None = None,
    ahead: CsvAhead | None = None,
) -> Path:
    """Write the table; ``aliases`` renames columns (single-FMU runs use variable names).

    ``ahead``: rows formatted while a guarded run went on (:mod:`.csvahead`), used where they
    hold exactly the result's values; the bytes are the same with or without it.
    """
    header = ["time", *((aliases or {}).get(n, n) for n in result.signals)]
    columns = result_columns(result)
    with atomic_text(path) as stream:  # never half-written, never through a planted link
        stream.write(",".join(_quote(h) for h in header) + "\n")
        if all(_exact_as_float(column) for column in columns):
            write_rows(stream, result_table(result), ahead=ahead)
        else:  # rows formatted ahead hold float64, which rounds these integers: not used
            write_columns(stream, columns)
    return path


#: Whole numbers up to this magnitude are exact float64 values, and a float64 whole number
#: below 1e16 is written as its digits: such integer columns write the same text either way.
_EXACT_WHOLE = 2**53


def _exact_as_float(column: npt.NDArray[Any]) -> bool:
    """Whether ``column`` writes the same text as float64 (:func:`format_rows`) as from its
    own integers: a float column, or integers no larger than 2**53 in magnitude, so that a
    system with 64-bit integer ports still uses the rows formatted ahead in the common case."""
    if column.dtype.kind not in "iu" or column.size == 0:
        return True
    if column.dtype.kind == "u":
        return int(column.max()) <= _EXACT_WHOLE
    return int(column.min()) >= -_EXACT_WHOLE and int(column.max()) <= _EXACT_WHOLE


def result_columns(result: RunResult) -> list[npt.NDArray[Any]]:
    """``time``, then each signal in the result's order, each in its own dtype (none: a run
    that recorded nothing, see :func:`result_table`)."""
    from fmionnx.results import nothing_recorded

    if nothing_recorded(result):
        return []
    return [result.time, *result.signals.values()]


def result_table(result: RunResult) -> npt.NDArray[np.float64]:
    """The numbers of ``results.csv``: ``time``, then each signal in the result's order, as
    float64 (integer columns rounded: :func:`write_csv` writes those from the columns).

    A run that recorded nothing has no row: its start time alone, with no value beside it,
    was a row that said nothing (a bug hunt)."""
    columns = result_columns(result)
    if not columns:
        return np.empty((0, 1))
    return np.column_stack(columns).astype(np.float64, copy=False)


def write_columns(stream: IO[str], columns: Sequence[npt.NDArray[Any]]) -> None:
    """Write ``columns`` (of equal length) as CSV lines: integer columns as whole numbers,
    the others as :func:`write_rows` writes them, in blocks of :data:`BLOCK_ROWS`."""
    rows = len(columns[0]) if columns else 0
    for first in range(0, rows, BLOCK_ROWS):
        block = [column[first : first + BLOCK_ROWS] for column in columns]
        texts = [_texts(column) for column in block]
        stream.write("\n".join(map(",".join, zip(*texts, strict=True))) + "\n")


def _texts(column: npt.NDArray[Any]) -> list[str]:
    """Every value of ``column`` as text: an integer's digits, a float's shortest decimal."""
    if column.dtype.kind in "iu":
        return [str(value) for value in column.tolist()]
    return column_texts(np.asarray(column, dtype=np.float64))


def write_rows(
    stream: IO[str],
    table: npt.NDArray[np.float64],
    *,
    ahead: CsvAhead | None = None,
) -> None:
    """Write ``table`` as CSV lines, every number as its shortest round-tripping decimal.

    The time goes into formatting floats, so no cell is formatted in a Python-level loop:
    each column of a block is formatted by :func:`column_texts` (C-level ``repr`` of a list),
    and the rows are assembled with ``zip`` and ``str.join``, also in C. That is about a
    third faster than formatting each distinct value with :func:`shortest_decimal` and
    several times faster than ``numpy.savetxt``; the bytes are the same (a test compares
    them over random, special and subnormal values).

    ``ahead`` (rows formatted ahead): its pieces that hold exactly the table's values are
    written as they are; the rest is formatted here.
    """
    floats = np.asarray(table, dtype=np.float64)
    first = 0
    while first < len(floats):
        if ahead is not None:
            done = ahead.text(floats, first)
            if done is not None:
                stream.write(done[0])
                first += done[1]
                continue
        last = min(len(floats), first + BLOCK_ROWS)
        if ahead is not None:
            last = min(last, ahead.next_start(first) or last)
        stream.write(format_rows(floats[first:last]))
        first = last


def format_rows(block: npt.NDArray[np.float64]) -> str:
    """The CSV lines of ``block`` (each ending in a newline); see :func:`write_rows`."""
    if block.shape[1] == 0:  # no column: empty lines, as many as rows
        return "\n" * len(block)
    columns = [column_texts(block[:, j]) for j in range(block.shape[1])]
    return "\n".join(map(",".join, zip(*columns, strict=True))) + "\n"


def column_texts(column: npt.NDArray[np.float64]) -> list[str]:
    """:func:`shortest_decimal` of every value of ``column``, computed in C.

    Held outputs repeat a value for many base steps, so only the first value of each run of
    equal bit patterns is formatted (bit patterns, not values: ``-0.0`` after ``0.0`` is a
    new run, and so is every NaN). ``repr`` of a list formats its floats exactly as ``repr``
    of each; the list's ``", "`` separators then split it, and a whole number's ``.0`` goes
    where it is followed by a separator (``", "`` never occurs inside a number's text).
    """
    bits = np.ascontiguousarray(column).view(np.uint64)
    if len(bits) == 0:
        return []
    starts = np.empty(len(bits), dtype=bool)
    starts[0] = True
    np.not_equal(bits[1:], bits[:-1], out=starts[1:])
    values = column.tolist() if starts.all() else column[starts].tolist()
    text = (repr(values)[1:-1] + ", ").replace(".0, ", ", ")
    texts = text[:-2].split(", ")
    if len(texts) == len(bits):
        return texts
    runs = np.cumsum(starts) - 1
    held: list[str] = np.array(texts, dtype=object)[runs].tolist()
    return held


def shortest_decimal(value: float) -> str:
    """The shortest text that reads back as ``value`` (``0.004``, ``1``, ``1e-05``, ``nan``)."""
    return repr(value).removesuffix(".0")


def _quote(name: str) -> str:
    return f'"{name}"' if "," in name or '"' in name else name


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a results.csv back into columns (for tests and plots of earlier runs)."""
    import csv
    import io

    with path.open(encoding="utf-8", newline="") as stream:
        # names of tensor elements hold commas (`detector.blobX[0,2]`) and come quoted
        header = next(csv.reader([stream.readline()]))
        rest = stream.read()
    if not rest.strip():  # a run that recorded nothing: no row
        return {name: np.empty(0) for name in header}
    data = np.loadtxt(io.StringIO(rest), delimiter=",", ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}
