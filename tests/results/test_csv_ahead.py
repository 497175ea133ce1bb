"""``results.csv`` formatted while a guarded run goes on (:mod:`fmionnx.results.csvahead`).

The file must be byte for byte what an unguarded run writes, whether the run completes or
faults midway, with several rates, held values and an output interval; pieces formatted
ahead are used only where they hold exactly the result's values.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.results import csvahead
from fmionnx.results.csvahead import PIECE_ROWS, CsvAhead
from fmionnx.results.csvfile import write_csv, write_rows
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.backends.test_isolation import SEGFAULT
from tests.backends.test_native_group import _multi_rate


@pytest.fixture
def write_system(tmp_path: Path):  # as tests/backends' fixture
    def write(text: str) -> Path:
        path = tmp_path / "system.yaml"
        path.write_text(text, encoding="utf-8")
        return path

    return write


#: Base steps: beyond three pieces, and beyond the 65 536 rows a shared track reserves first
#: (so the tracks moved once while the guardian read them).
STEPS = 70_000


def _long(fixture_fmu, write_system, tmp_path: Path, *, interval: str = "") -> Path:
    path = _multi_rate(fixture_fmu, write_system)
    text = path.read_text(encoding="utf-8")
    run = f"run: {{stop: {STEPS * 0.01:g}, step: 0.01{interval}}}"
    longer = tmp_path / f"long{len(interval)}.yaml"
    longer.write_text(text.replace("run: {stop: 0.6, step: 0.01}", run), encoding="utf-8")
    return longer


def _csv(result: RunResult, path: Path, ahead: CsvAhead | None = None) -> bytes:
    write_csv(result, path, ahead=ahead)
    return path.read_bytes()


def _guarded(path: Path) -> tuple[RunResult, CsvAhead]:
    system = fmionnx.load(path)
    ahead = CsvAhead(system.compiled)
    result = run_guarded(system.compiled, system.run, RunOptions(), follower=ahead)
    return result, ahead


@pytest.mark.parametrize("interval", ["", ", output_interval: 0.03"])
def test_a_multi_rate_guarded_run_writes_the_bytes_of_an_unguarded_one(
    fixture_fmu, write_system, tmp_path: Path, interval: str
) -> None:
    path = _long(fixture_fmu, write_system, tmp_path, interval=interval)
    plain = fmionnx.load(path).run(isolate="none")
    assert plain.status is RunStatus.COMPLETED
    guarded, ahead = _guarded(path)
    assert guarded.status is RunStatus.COMPLETED
    assert ahead.rows >= PIECE_ROWS  # the guardian did format rows while the child ran
    expected = _csv(plain, tmp_path / "plain.csv")
    assert _csv(guarded, tmp_path / "ahead.csv", ahead) == expected
    assert _csv(guarded, tmp_path / "guarded.csv") == expected
    assert expected.count(b"\n") == len(plain.time) + 1


def test_a_run_that_crashes_midway_keeps_exactly_the_completed_rows(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    fail_at = 600.0  # step 60 000: pieces were formatted before the crash
    path = write_system(
        f"""
fmionnx: 1
name: crashing
run: {{stop: {STEPS * 0.01:g}, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{u: {{ramp: {{slope: 2}}}}}}}}
  slow: {{kind: fmu, path: {fixture_fmu("Integrator")}, period: 0.03}}
  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {SEGFAULT}, failAt: {fail_at}}}}}
connections:
  - src.u -> bad.u
  - src.u -> slow.u
record: [bad.u, bad.y, slow.x]
"""
    )  # fmt: skip
    result, ahead = _guarded(path)
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert "SIGSEGV" in str(result.error)
    assert result.time[-1] == fail_at
    assert ahead.rows >= PIECE_ROWS
    # The same rows as a run stopped at the crash's time, byte for byte
    shortened = fmionnx.load(path).run(isolate="none", stop_time=fail_at)
    lines = _csv(result, tmp_path / "ahead.csv", ahead).splitlines()
    assert lines == _csv(shortened, tmp_path / "plain.csv").splitlines()
    assert len(lines) == round(fail_at / 0.01) + 2  # the header, the start and every step


def test_a_piece_whose_values_differ_from_the_result_is_not_used(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    path = _long(fixture_fmu, write_system, tmp_path)
    result, ahead = _guarded(path)
    pieces = ahead._pieces
    first = min(pieces)
    table = np.column_stack([result.time, *result.signals.values()])
    assert ahead.text(table, first) is not None
    forged = table.copy()
    forged[first + 5, 1] = np.nextafter(forged[first + 5, 1], np.inf)  # one bit off
    assert ahead.text(forged, first) is None
    assert ahead.text(table[: first + 10], first) is None  # the table ends inside the piece
    assert ahead.text(table, first + 1) is None  # no piece starts there
    for rows in (forged, table[: first + PIECE_ROWS // 2]):
        with_ahead, without = io.StringIO(), io.StringIO()
        write_rows(with_ahead, rows, ahead=ahead)
        write_rows(without, rows)
        assert with_ahead.getvalue() == without.getvalue()


def test_formatting_ahead_stops_at_its_memory_bound(
    fixture_fmu, write_system, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(csvahead, "MAX_AHEAD_BYTES", 1)  # one piece, then no more
    path = _long(fixture_fmu, write_system, tmp_path)
    result, ahead = _guarded(path)
    assert ahead.rows == PIECE_ROWS
    plain = fmionnx.load(path).run(isolate="none")
    assert _csv(result, tmp_path / "ahead.csv", ahead) == _csv(plain, tmp_path / "plain.csv")
