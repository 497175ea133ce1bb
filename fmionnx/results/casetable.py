"""A study's table of cases, and its two files, without pandas.

The study's driver builds the table from the records and writes ``cases.parquet`` (pyarrow)
and ``cases.csv`` (the csv module). pandas costs about 0.4 CPU-s to import, which on a busy
machine is time the cases do not get (``docs/performance.md``, eighth pass); a Python caller
of :func:`fmionnx.sweep` still gets a :class:`pandas.DataFrame` (:meth:`CaseTable.to_pandas`).

Each column is given the type pandas (3) would infer from the same rows, so that both files
are what ``pandas.DataFrame(rows).to_csv(index=False)`` and ``pyarrow.Table.from_pandas`` wrote
before (``tests/results/test_case_table.py`` compares them on tables of every kind):

* booleans only → bool; integers only → int64 (uint64 past it);
* integers and floats, or numbers with a gap → float64 (``1`` is written ``1.0``);
* text only → pandas' ``str`` (a ``large_string`` in parquet);
* anything else → objects, written as ``str`` gives them; in parquet, where pandas hands
  pyarrow a column it may refuse, float64 when every value is a number a float holds, else
  their text;
* NaN and None → an empty cell (a null in parquet).
"""

from __future__ import annotations

import csv
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import IO, TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    import numpy.typing as npt
    import pandas as pd
    import pyarrow as pa

#: A column's type, as pandas infers it from Python values.
ColumnKind = Literal["bool", "int", "uint", "float", "text", "object", "empty"]
#: The ranges of pandas' int64 and uint64 columns; beyond both, a column of objects.
INT64, UINT64 = (-(2**63), 2**63 - 1), (0, 2**64 - 1)


@dataclass(frozen=True)
class CaseTable:
    """One row per case with a record, in case order; ``columns`` names each row's cells."""

    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]

    def __post_init__(self) -> None:
        for row in self.rows:
            if len(row) != len(self.columns):
                msg = f"a row of {len(row)} cells in a table of {len(self.columns)} columns"
                raise ValueError(msg)

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def empty(self) -> bool:
        """No row at all."""
        return not self.rows

    @functools.cached_property
    def _positions(self) -> dict[str, int]:
        """Each column's place in a row (a study may have thousands of metrics)."""
        return {name: place for place, name in enumerate(self.columns)}

    def column(self, name: str) -> list[Any]:
        """The cells of column ``name``, top to bottom (KeyError: no such column)."""
        place = self._positions[name]
        return [row[place] for row in self.rows]

    def records(self) -> list[dict[str, Any]]:
        """Each row as a mapping of column to cell; an integer in a column of floats as a
        float, as pandas has it."""
        floats = [name for name in self.columns if self.kind(name) == "float"]
        records = [dict(zip(self.columns, row, strict=True)) for row in self.rows]
        for record in records:
            for name in floats:
                record[name] = math.nan if record[name] is None else float(record[name])
        return records

    @functools.cached_property
    def _kinds(self) -> dict[str, ColumnKind]:
        """Each column's type, worked out once (both files and the DataFrame use them)."""
        return {name: column_kind(self.column(name)) for name in self.columns}

    def kind(self, name: str) -> ColumnKind:
        """The type pandas gives column ``name``."""
        return self._kinds[name]

    def to_pandas(self) -> pd.DataFrame:
        """The table as the DataFrame pandas makes of the same rows."""
        import pandas as pd

        return pd.DataFrame(self.records(), columns=list(self.columns))

    def to_arrow(self) -> pa.Table:
        """The table as ``pyarrow.Table.from_pandas(self.to_pandas())`` gives it, without its
        pandas metadata (pandas reads the file back to the same frame)."""
        import pyarrow as pa

        arrays = [_arrow(self.column(name), self.kind(name)) for name in self.columns]
        return pa.Table.from_arrays(arrays, names=list(self.columns))

    def write_csv(self, stream: IO[str]) -> None:
        """The table as CSV, as ``to_csv(index=False, lineterminator="\\n")`` writes it."""
        kinds = [self.kind(name) for name in self.columns]
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(self.columns)
        for row in self.rows:
            writer.writerow([_text(cell, kind) for cell, kind in zip(row, kinds, strict=True)])


def column_kind(values: Sequence[Any]) -> ColumnKind:
    """The type pandas infers for a column of these Python values (None is missing, as NaN)."""
    if not values:
        return "empty"
    present = [v for v in values if not _missing(v)]
    missing = len(present) < len(values)
    if present and all(isinstance(v, bool) for v in present):
        return "object" if missing else "bool"
    if any(isinstance(v, bool) for v in present):
        return "object"
    if present and not missing and all(isinstance(v, int) for v in present):
        if all(INT64[0] <= v <= INT64[1] for v in present):
            return "int"
        return "uint" if all(UINT64[0] <= v <= UINT64[1] for v in present) else "object"
    numbers = all(isinstance(v, int | float) for v in present)
    if numbers and (present or any(isinstance(v, float) for v in values)):
        wide = any(isinstance(v, int) and not INT64[0] <= v <= UINT64[1] for v in present)
        return "object" if wide else "float"
    if present and all(isinstance(v, str) for v in present):
        return "text"
    return "object"


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def _text(value: Any, kind: ColumnKind) -> str:
    """A cell as pandas writes it in a column of ``kind``."""
    if _missing(value):
        return ""
    if kind == "float":
        return repr(float(value))
    return str(value)


def _plain_number(value: Any) -> bool:
    """Whether ``value`` is a number float64 holds (a bool counts, as pyarrow takes it)."""
    if not isinstance(value, int | float):
        return False
    try:
        float(value)
    except OverflowError:
        return False
    return True


def _arrow(values: list[Any], kind: ColumnKind) -> pa.Array:
    """A column as pyarrow converts pandas' column of the same values (NaN is null).

    Built from its buffers: ``pyarrow.array`` imports pandas, to ask whether what it is given
    is a pandas column, even for a numpy array."""
    import numpy as np
    import pyarrow as pa

    if kind == "empty":
        return pa.nulls(0)
    missing = np.array([_missing(v) for v in values], dtype=np.bool_)
    nulls = int(missing.sum())
    validity = pa.py_buffer(np.packbits(~missing, bitorder="little")) if nulls else None
    if kind == "text":
        return _text_array([None if _missing(v) else str(v) for v in values], validity)
    numbers = {
        "bool": (pa.bool_(), np.bool_),
        "int": (pa.int64(), np.int64),
        "uint": (pa.uint64(), np.uint64),
        "float": (pa.float64(), np.float64),
    }
    if kind == "object":  # mixed types: as one type pyarrow can hold, never refused
        present = [v for v in values if not _missing(v)]
        if not present:
            return pa.nulls(len(values))
        if all(isinstance(v, bool) for v in present):
            kind = "bool"  # booleans with a gap: nullable booleans
        elif all(_plain_number(v) for v in present):
            kind = "float"  # as pyarrow reads [0.5, 1, True]: 0.5, 1.0, 1.0
        else:
            return _text_array([None if _missing(v) else str(v) for v in values], validity)
    arrow_type, dtype = numbers[kind]
    data: npt.NDArray[Any] = np.array([0 if _missing(v) else v for v in values], dtype=dtype)
    if kind == "bool":
        data = np.packbits(data, bitorder="little")
    buffers = [validity, pa.py_buffer(data)]
    return pa.Array.from_buffers(arrow_type, len(values), buffers, null_count=nulls)


def _text_array(texts: list[str | None], validity: pa.Buffer | None) -> pa.Array:
    """A ``large_string`` column from its buffers (None: a null, marked in ``validity``)."""
    import numpy as np
    import pyarrow as pa

    encoded = [b"" if t is None else t.encode("utf-8", "backslashreplace") for t in texts]
    offsets = np.zeros(len(texts) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(e) for e in encoded])
    buffers = [validity, pa.py_buffer(offsets), pa.py_buffer(b"".join(encoded))]
    nulls = sum(t is None for t in texts)
    return pa.Array.from_buffers(pa.large_string(), len(texts), buffers, null_count=nulls)
