"""results.csv numbers: the shortest decimal that reads back as the same float64 (issue #16).

``0.0040000000000000001`` (17 significant digits) round-trips too, but reads as noise; the
writer must give ``0.004`` and still return every bit, ``-0.0`` and subnormals included.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from fmionnx.results import csvfile
from fmionnx.results.csvfile import read_csv, shortest_decimal, write_csv, write_rows
from fmionnx.runtime.result import RunResult, RunStatus


def _result(time: np.ndarray, **signals: np.ndarray) -> RunResult:
    return RunResult(
        system="demo", backend="inprocess", status=RunStatus.COMPLETED, start=0.0,
        stop=float(time[-1]), step=0.002, steps_done=len(time) - 1, wall_time=0.01,
        time=time, signals=signals,
    )  # fmt: skip


def test_times_are_written_as_their_shortest_decimal(tmp_path: Path) -> None:
    time = np.arange(4) * 0.002  # 0.004 is 0.0040000000000000001 to 17 digits
    result = _result(time, **{"a.y": np.array([1.0, -0.0, 1e-5, 0.1 + 0.2])})
    lines = write_csv(result, tmp_path / "results.csv").read_text(encoding="utf-8").splitlines()
    assert lines == [
        "time,a.y",
        "0,1",
        "0.002,-0",
        "0.004,1e-05",
        "0.006,0.30000000000000004",
    ]


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0.004, "0.004"), (2.0, "2"), (-0.0, "-0"), (1e16, "1e+16"), (2.5e-300, "2.5e-300"),
        (5e-324, "5e-324"), (float("nan"), "nan"), (float("-inf"), "-inf"), (100.5, "100.5"),
    ],
)  # fmt: skip
def test_shortest_decimal(value: float, text: str) -> None:
    assert shortest_decimal(value) == text


finite_tables = hnp.arrays(
    np.float64,
    hnp.array_shapes(min_dims=2, max_dims=2, max_side=12),
    elements=st.floats(allow_nan=False, width=64),
)


@settings(max_examples=200, deadline=None)
@given(finite_tables)
def test_every_float64_reads_back_bit_for_bit(table: np.ndarray) -> None:
    stream = io.StringIO()
    write_rows(stream, table)
    lines = stream.getvalue().splitlines()
    assert len(lines) == table.shape[0]
    back = np.array([[float(cell) for cell in line.split(",")] for line in lines])
    assert back.reshape(table.shape).tobytes() == table.tobytes()


def test_blocks_of_rows_join_seamlessly(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    time = np.arange(10) * 0.1
    result = _result(time, **{"a.y": np.sin(time), "b.z": np.repeat([0.5, -0.0], 5)})
    whole = write_csv(result, tmp_path / "whole.csv").read_text(encoding="utf-8")
    monkeypatch.setattr(csvfile, "BLOCK_ROWS", 3)
    blocked = write_csv(result, tmp_path / "blocked.csv").read_text(encoding="utf-8")
    assert blocked == whole
    table = read_csv(tmp_path / "blocked.csv")
    assert table["a.y"].tobytes() == np.sin(time).tobytes()


def _reference_rows(table: np.ndarray) -> str:
    """The format by definition: :func:`shortest_decimal` of every cell, one cell at a time."""
    return "".join(",".join(shortest_decimal(v) for v in row) + "\n" for row in table.tolist())


def _awkward_values(rng: np.random.Generator, n: int) -> np.ndarray:
    """Random bit patterns (NaN payloads, subnormals, huge and tiny numbers), the special
    values, whole numbers of every size, and runs of held values, in a random order."""
    bits = rng.integers(0, 2**64, size=n, dtype=np.uint64, endpoint=False).view(np.float64)
    special = np.array(
        [0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, 5e-324, -5e-324, 2.2250738585072014e-308,
         1.7976931348623157e308, 1e15, 1e16, 1e17, 123456789012345678.0, 0.1, 1e-05, 1e-4,
         9007199254740993.0, -1.0, 2.0**63, 1.5, 100.0, 1e22, 1e-7],
    )  # fmt: skip
    subnormal = rng.integers(1, 2**52, size=n // 4, dtype=np.uint64).view(np.float64)
    whole = rng.integers(-(2**62), 2**62, size=n // 4).astype(np.float64)
    small_whole = rng.integers(-1000, 1000, size=n // 4).astype(np.float64)
    uniform = rng.uniform(-1e3, 1e3, size=n // 4)
    held = np.repeat(rng.normal(size=n // 40 + 1), 10)
    values = np.concatenate([bits, special, subnormal, whole, small_whole, uniform, held])
    return rng.permutation(values)


@pytest.mark.parametrize("seed", range(4))
def test_the_fast_writer_gives_the_reference_bytes(seed: int) -> None:
    rng = np.random.default_rng(seed)
    values = _awkward_values(rng, 4000)
    columns = 1 + seed
    table = values[: len(values) // columns * columns].reshape(-1, columns)
    table[:, 0] = np.sort(np.abs(rng.normal(size=len(table))))  # a time-like column
    if seed % 2:  # a held column and a constant one too
        table = np.column_stack(
            [table, np.repeat(table[::7, -1], 7)[: len(table)], np.zeros(len(table))]
        )
    stream = io.StringIO()
    write_rows(stream, table)
    assert stream.getvalue() == _reference_rows(table)


@pytest.mark.parametrize("shape", [(0, 3), (5, 0), (1, 1), (3, 1)])
def test_degenerate_tables_give_the_reference_bytes(shape: tuple[int, int]) -> None:
    table = np.arange(shape[0] * shape[1], dtype=np.float64).reshape(shape) - 1.0
    stream = io.StringIO()
    write_rows(stream, table)
    assert stream.getvalue() == _reference_rows(table)


def test_runs_of_values_that_compare_equal_but_differ_in_bits_stay_apart() -> None:
    column = np.array([0.0, -0.0, -0.0, 0.0, np.nan, np.nan, 1.0, 1.0])
    stream = io.StringIO()
    write_rows(stream, column.reshape(-1, 1))
    assert stream.getvalue().split() == ["0", "-0", "-0", "0", "nan", "nan", "1", "1"]
