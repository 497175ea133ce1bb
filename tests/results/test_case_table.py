"""A study's table without pandas: the files it writes are the ones pandas wrote from the same
rows (``cases.csv`` byte for byte, ``cases.parquet`` column for column), and a caller still
gets the same DataFrame."""

from __future__ import annotations

import io
import math
from typing import Any

import pandas as pd
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fmionnx.results.casetable import CaseTable, column_kind

COLUMNS = ("case", "gain.k", "mixed", "flag", "mode", "array", "metric", "check: ok", "status")
ROWS = (
    ("case-0000", 1, 1, True, "a", "[1.0, 2.0]", 0.1 + 0.2, True, "ok"),
    ("case-0001", 2, 2.5, False, 'say "hi", then', "[3.0]", math.nan, False, "fault"),
    ("case-0002", 3, -0.0, True, "line\nbreak", "[]", 1e-05, True, "ok"),
    ("case-0003", 10**12, 1e22, False, "", "[-1e+16]", math.inf, False, "timeout"),
)


def _frame(table: CaseTable) -> pd.DataFrame:
    """What pandas makes of the table's rows, untouched (not through :meth:`to_pandas`)."""
    rows = [dict(zip(table.columns, row, strict=True)) for row in table.rows]
    return pd.DataFrame(rows, columns=list(table.columns))


def _pandas_csv(table: CaseTable) -> str:
    stream = io.StringIO()
    _frame(table).to_csv(stream, index=False, lineterminator="\n")
    return stream.getvalue()


def _own_csv(table: CaseTable) -> str:
    stream = io.StringIO()
    table.write_csv(stream)
    return stream.getvalue()


def _same_arrow(table: CaseTable) -> None:
    ours = table.to_arrow()
    ours.validate(full=True)
    theirs = pa.Table.from_pandas(_frame(table), preserve_index=False)
    assert ours.schema.remove_metadata() == theirs.schema.remove_metadata()
    assert ours.to_pylist() == theirs.to_pylist() or _equal_with_nan(ours, theirs)


def _equal_with_nan(ours: pa.Table, theirs: pa.Table) -> bool:
    def plain(value: Any) -> Any:
        return "nan" if isinstance(value, float) and math.isnan(value) else value

    return [{k: plain(v) for k, v in r.items()} for r in ours.to_pylist()] == [
        {k: plain(v) for k, v in r.items()} for r in theirs.to_pylist()
    ]


def test_every_kind_of_column_is_written_as_pandas_wrote_it() -> None:
    table = CaseTable(COLUMNS, ROWS)
    assert [table.kind(c) for c in COLUMNS] == [
        "text", "int", "float", "bool", "text", "text", "float", "bool", "text",
    ]  # fmt: skip
    assert _own_csv(table) == _pandas_csv(table)
    assert '"say ""hi"", then"' in _own_csv(table)  # quoted as the csv module quotes
    assert ",1.0," in _own_csv(table)  # an integer among floats is a float, as in pandas
    _same_arrow(table)


def test_the_dataframe_is_the_one_pandas_makes_of_the_rows() -> None:
    table = CaseTable(COLUMNS, ROWS)
    expected = pd.DataFrame([dict(zip(COLUMNS, r, strict=True)) for r in ROWS], columns=COLUMNS)
    pd.testing.assert_frame_equal(table.to_pandas(), expected)
    assert [str(t) for t in table.to_pandas().dtypes] == [
        "str", "int64", "float64", "bool", "str", "str", "float64", "bool", "str",
    ]  # fmt: skip


def test_a_table_without_rows_is_its_header() -> None:
    table = CaseTable(COLUMNS, ())
    assert table.empty
    assert _own_csv(table) == _pandas_csv(table) == ",".join(COLUMNS) + "\n"
    _same_arrow(table)


def test_missing_values_are_empty_cells_and_nulls() -> None:
    table = CaseTable(("case", "metric", "note"), (("a", math.nan, None), ("b", 2.0, "x")))
    assert _own_csv(table) == _pandas_csv(table) == "case,metric,note\na,,\nb,2.0,x\n"
    _same_arrow(table)
    assert table.to_arrow().column("metric").null_count == 1


@pytest.mark.parametrize(
    ("values", "kind"),
    [
        ([], "empty"),
        ([True, False], "bool"),
        ([True, 1], "object"),
        ([1, 2], "int"),
        ([1, 2**63], "uint"),
        ([-1, 2**63], "object"),
        ([1, 2.0], "float"),
        ([1, "a"], "object"),
        ([math.nan, 1], "float"),
        (["a", None], "text"),
        ([None, None], "object"),
        ([1, None], "float"),
        ([None, math.nan], "float"),
        ([0.5, 10**20], "object"),
        ([2**63, 0.5], "float"),
        ([True, None], "object"),
    ],
)
def test_a_column_has_the_type_pandas_gives_it(values: list[Any], kind: str) -> None:
    assert column_kind(values) == kind
    if kind == "empty":
        return  # a table without rows: test_a_table_without_rows_is_its_header
    frame = pd.DataFrame({"x": values})
    expected = {"bool": "bool", "int": "int64", "uint": "uint64", "float": "float64", "text": "str"}
    assert str(frame["x"].dtype) == expected.get(kind, "object")


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=True, allow_infinity=True),
            st.integers(min_value=-(2**63), max_value=2**64 - 1),
            st.text(max_size=8),
        ),
        max_size=6,
    )
)
def test_any_floats_integers_and_text_are_written_as_pandas_wrote_them(
    rows: list[tuple[float, int, str]],
) -> None:
    table = CaseTable(("metric", "count", "message"), tuple(rows))
    assert _own_csv(table) == _pandas_csv(table)
    if table.kind("count") != "object":
        _same_arrow(table)
    else:  # mixed signs past int64: pandas hands pyarrow what it refuses; written as floats
        assert table.to_arrow().column("count").type == pa.float64()


@pytest.mark.parametrize(
    ("values", "arrow"),
    [
        ([1, 10**20], pa.float64()),  # a study of a float parameter may set both
        ([0.5, 1, True], pa.float64()),  # a study's axis may mix them (as pyarrow reads it)
        (["a", 1], pa.large_string()),
        ([10**400, 1.5], pa.large_string()),  # beyond a float: its text, as in cases.csv
        ([True, None], pa.bool_()),
        ([None, None], pa.null()),
    ],
)
def test_a_column_of_mixed_values_is_written_without_pandas(
    values: list[Any], arrow: pa.DataType
) -> None:
    table = CaseTable(("case", "x"), tuple((f"c{i}", v) for i, v in enumerate(values)))
    column = table.to_arrow().column("x")
    column.validate(full=True)
    assert column.type == arrow
    assert _own_csv(table) == _pandas_csv(table)


def test_the_best_cases_come_first_and_ties_in_case_order() -> None:
    from types import SimpleNamespace

    from fmionnx.results.study import ranked

    table = CaseTable(
        ("case", "y", "status"),
        (("c3", 2.0, "ok"), ("c1", 2.0, "ok"), ("c2", 5.0, "ok"), ("c0", 9.0, "fault"),
         ("c4", math.nan, "ok")),
    )  # fmt: skip
    best = SimpleNamespace(objective=SimpleNamespace(metric="y", sense="maximize"))
    least = SimpleNamespace(objective=SimpleNamespace(metric="y", sense="minimize"))
    assert [r["case"] for r in ranked(table, best)] == ["c2", "c1", "c3"]  # type: ignore[arg-type]
    assert [r["case"] for r in ranked(table, least)] == ["c1", "c3", "c2"]  # type: ignore[arg-type]
    assert ranked(table, SimpleNamespace(objective=None)) == []  # type: ignore[arg-type]
