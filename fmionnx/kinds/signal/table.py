"""CSV signal tables: read once, checked strictly, every problem named by ``file:line``.

Layout: a header line (the time column's name, then one port name per value column), then
one row per time; times increase strictly; blank lines are skipped and fields trimmed; values
are finite numbers. Reading is the standard library's ``csv`` module on UTF-8 text.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import MODEL_FILE_BYTES
from fmionnx.core.types import Causality, ComponentInterface, DType, Port
from fmionnx.kinds.cache import sha256_file
from fmionnx.kinds.signal.names import NAME, PORT_NAME


@dataclass(frozen=True, slots=True)
class Table:
    """A checked table: strictly increasing ``times`` and one row of values per time."""

    names: tuple[str, ...]
    times: tuple[float, ...]
    rows: tuple[tuple[float, ...], ...]


def _bad(where: str, message: str, hint: str | None = None) -> ModelError:
    return ModelError(codes.BAD_MODEL, f"`{where}`: {message}", hint=hint)


#: A decimal number as a CSV holds one: Python's ``float`` also takes ``1_000``, surrounding
#: blanks and ``infinity``, which no other reader of the table (a spreadsheet, numpy's
#: ``loadtxt`` of another tool) reads the same way.
_DECIMAL = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")


def _number(where: str, column: str, cell: str) -> float:
    if not cell:
        raise _bad(where, f"column `{column}` is empty")
    if _DECIMAL.fullmatch(cell) is None:
        lowered = cell.strip().lower().lstrip("+-")
        if lowered in ("nan", "inf", "infinity"):
            raise _bad(where, f"column `{column}`: `{cell}` is not a finite number")
        raise _bad(where, f"column `{column}`: `{cell}` is not a number")
    try:
        value = float(cell)
    except ValueError:  # pragma: no cover - the pattern admits only what float reads
        raise _bad(where, f"column `{column}`: `{cell}` is not a number") from None
    if not math.isfinite(value):
        raise _bad(where, f"column `{column}`: `{cell}` is not a finite number")
    return value


def _header(file: str, line: int, header: list[str]) -> tuple[str, ...]:
    where = f"{file}:{line}"
    layout = "the first line names the columns: the time, then one port name per value column"
    try:
        float(header[0])
    except ValueError:
        pass
    else:
        raise _bad(where, "the first line holds numbers, not column names", hint=layout)
    names = tuple(header[1:])
    if not names:
        raise _bad(where, "the table has no value column", hint=layout)
    for name in names:
        if not PORT_NAME.fullmatch(name):
            raise _bad(
                where,
                f"column name `{name}` is not a port name",
                hint="use letters, digits and `_`, not starting with a digit",
            )
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise _bad(where, f"column `{duplicates[0]}` appears twice")
    return names


def read_table(path: Path) -> Table:
    """Read and check a signal table.

    Raises ModelError: E010 missing, E011 not a file, E012 unreadable, not UTF-8, or
    malformed, naming ``<file>:<line>`` (blank lines are skipped, fields are trimmed).
    """
    if not path.exists():
        msg = f"`{path}` does not exist"
        raise ModelError(codes.FILE_NOT_FOUND, msg)
    if not path.is_file():
        msg = f"`{path}` is not a file"
        raise ModelError(codes.NOT_A_FILE, msg)
    file = path.name
    try:  # a regular file of bounded size, even if swapped since the look above
        text = read_regular(path, MODEL_FILE_BYTES, f"`{file}`").decode("utf-8-sig")
    except UnicodeDecodeError:
        msg = f"`{file}` is not UTF-8 text"
        raise ModelError(codes.BAD_MODEL, msg) from None
    except OSError as exc:
        msg = f"`{file}` cannot be read: {exc.strerror or exc}"
        raise ModelError(codes.BAD_MODEL, msg) from None
    records: list[tuple[int, list[str]]] = []
    reader = csv.reader(text.splitlines(), strict=True)
    try:
        for record in reader:
            cells = [cell.strip() for cell in record]
            if any(cells):
                records.append((reader.line_num, cells))
    except csv.Error as exc:
        raise _bad(f"{file}:{reader.line_num}", str(exc)) from None
    if not records:
        msg = f"`{file}` is empty"
        raise ModelError(
            codes.BAD_MODEL, msg, hint="write a header line (`time,<port>,...`), then rows"
        )
    names = _header(file, *records[0])
    if len(records) == 1:
        msg = f"`{file}` has a header but no rows"
        raise ModelError(codes.BAD_MODEL, msg)
    times: list[float] = []
    rows: list[tuple[float, ...]] = []
    previous = 0
    for line, cells in records[1:]:
        where = f"{file}:{line}"
        if len(cells) != len(names) + 1:
            raise _bad(where, f"{len(cells)} fields, but the header names {len(names) + 1}")
        time = _number(where, "time", cells[0])
        if times and time <= times[-1]:
            raise _bad(
                where,
                f"time {cells[0]} is not after {times[-1]:g} (line {previous}); times must "
                "increase strictly",
            )
        times.append(time)
        rows.append(tuple(_number(where, n, c) for n, c in zip(names, cells[1:], strict=True)))
        previous = line
    return Table(names, tuple(times), tuple(rows))


def table_interface(path: Path) -> ComponentInterface:
    """One ``float64`` output per value column; facts: ``rows``, ``firstTime``, ``lastTime``."""
    table = read_table(path)
    ports = tuple(
        Port(
            name,
            Causality.OUTPUT,
            DType.FLOAT64,
            depends_on=(),
            description=f"column of {path.name}",
        )
        for name in table.names
    )
    facts = (
        ("rows", str(len(table.times))),
        ("firstTime", repr(table.times[0])),
        ("lastTime", repr(table.times[-1])),
    )
    return ComponentInterface(NAME, path, ports, facts, content_hash=sha256_file(path))
