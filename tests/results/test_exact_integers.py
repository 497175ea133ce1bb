"""64-bit integers recorded exactly (a bug hunt): results.csv rounded int64/uint64 outputs to
float64 (``y_u64`` 9008298766368769 written as ...768), though docs/running.md promises the
computed values exactly.

``Types3`` (a real FMI 3 FMU built from C) computes ``y_i64 = 3*u_i64 + 1`` and
``y_u64 = u_u64 + 2**40``; the inputs are chosen so that both outputs lie beyond 2**53. Every
way a run records is checked: the native kernel (``isolate none``), Python sampling through an
isolated FMU's proxy (``fmus``), the guardian's shared tracks (a lone FMU's default), and the
rows a guardian rebuilds after its child died (from the shared columns alone).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.results.csvfile import write_csv
from fmionnx.runtime.recorder import Recorder, Track
from fmionnx.runtime.result import RunResult, RunStatus
from tests.conftest import build_fixture_fmu

PARAMS = {"u_i64": 3002399751580332, "u_u64": 9007199254740993}
Y_I64 = 3 * 3002399751580332 + 1  # 9007199254740997: float64 reads ...996
Y_U64 = 9007199254740993 + 2**40  # 9008298766368769: float64 reads ...768


@pytest.mark.parametrize("isolate", ["none", "fmus", "guardian"])
def test_int64_and_uint64_outputs_reach_results_csv_exactly(tmp_path: Path, isolate: str) -> None:
    out = tmp_path / "out"
    outcome = fmionnx.run(
        build_fixture_fmu("Types3"), out=out, stop_time=0.2, isolate=isolate, params=PARAMS
    )
    result = outcome.result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["y_i64"].dtype == np.int64
    assert result.signals["y_u64"].dtype == np.uint64
    assert result.signals["y_i64"].tolist() == [Y_I64] * 3
    assert result.signals["y_u64"].tolist() == [Y_U64] * 3
    lines = (out / "results.csv").read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    for line in lines[1:]:
        cells = dict(zip(header, line.split(","), strict=True))
        assert cells["y_i64"] == str(Y_I64)
        assert cells["y_u64"] == str(Y_U64)
        assert cells["y_f32"] == cells["y_f32"]  # float columns beside them as before


def test_every_bit_pattern_survives_a_track_and_its_rebuilding() -> None:
    """Bytes that read as a signalling NaN in float64 come back unchanged, also from a track
    rebuilt from its columns alone (as the guardian does after a crash)."""
    values = np.array([0x7FF0000000000001, 0xFFF0000000000001, 2**64 - 1, 0], dtype=np.uint64)
    buffer = np.zeros(1, dtype=np.uint64)
    recorder = Recorder()
    track = recorder.track(1, len(values))
    track.add(["c.y"], buffer)
    recorder.order.append("c.y")
    track.allocate()
    for value in values:
        buffer[0] = value
        track.sample()
    assert recorder.table(len(values) - 1)["c.y"].tolist() == values.tolist()
    rebuilt = Recorder()
    rebuilt.order.append("c.y")
    copy = Track(1, track.capacity, list(track.columns))
    copy.rows, copy.count = track.rows[: track.count].copy(), track.count
    rebuilt.tracks.append(copy)
    assert rebuilt.table(len(values) - 1)["c.y"].tolist() == values.tolist()


def test_a_float_only_table_records_no_extra_column() -> None:
    recorder = Recorder()
    track = recorder.track(1, 4)
    track.add(["c.x"], np.zeros(1))
    track.add(["c.n"], np.zeros(1, dtype=np.int32))
    assert track.columns == ["c.x", "c.n"]


def test_integer_columns_are_written_digit_for_digit(tmp_path: Path) -> None:
    result = RunResult(
        system="ints",
        backend="inprocess",
        status=RunStatus.COMPLETED,
        start=0.0,
        stop=0.1,
        step=0.1,
        steps_done=1,
        wall_time=0.01,
        time=np.array([0.0, 0.1]),
        signals={
            "a.i": np.array([-(2**63), 2**53 + 1], dtype=np.int64),
            "a.u": np.array([2**64 - 1, 0], dtype=np.uint64),
            "a.x": np.array([0.1, 1e300]),
        },
    )
    text = write_csv(result, tmp_path / "results.csv").read_text(encoding="utf-8")
    assert text == (f"time,a.i,a.u,a.x\n0,{-(2**63)},{2**64 - 1},0.1\n0.1,{2**53 + 1},0,1e+300\n")


def _ints_result(values: list[int]) -> RunResult:
    return RunResult(
        system="ints", backend="inprocess", status=RunStatus.COMPLETED, start=0.0, stop=0.1,
        step=0.1, steps_done=1, wall_time=0.01, time=np.array([0.0, 0.1]),
        signals={"a.i": np.array(values, dtype=np.int64), "a.x": np.array([0.5, 1.5])},
    )  # fmt: skip


@pytest.mark.parametrize(
    ("values", "ahead_used"), [([-(2**53), 2**53], True), ([0, 2**53 + 1], False)]
)
def test_rows_formatted_ahead_serve_integer_columns_that_float64_holds(
    tmp_path: Path, values: list[int], ahead_used: bool
) -> None:
    """A system with an int64 port threw away every row formatted while its run went on (a
    re-read): integers within 2**53 are exact float64s and written as the same digits, so the
    pieces serve them; beyond it the columns are written from the integers, digit for digit."""
    from fmionnx.results.csvahead import CsvAhead
    from fmionnx.results.csvfile import result_table

    result = _ints_result(values)
    table = result_table(result)
    ahead = CsvAhead(0.0, 0.1, 1, piece_rows=2)
    ahead.adopt([(0, table, b"piece,formatted,ahead\n" * 2)])  # marked: was it used?
    text = write_csv(result, tmp_path / "results.csv", ahead=ahead).read_text(encoding="utf-8")
    assert ("piece,formatted,ahead" in text) is ahead_used
    plain = write_csv(result, tmp_path / "plain.csv").read_text(encoding="utf-8")
    assert plain.splitlines()[1:] == [
        f"{t:g},{v},{x:g}" for t, v, x in zip([0, 0.1], values, [0.5, 1.5], strict=True)
    ]
