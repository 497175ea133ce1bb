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
