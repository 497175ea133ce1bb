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
from fmionnx.runtime import guardian
from fmionnx.runtime.guardian import run_guarded
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.backends.test_isolation import SEGFAULT
from tests.backends.test_native_group import _multi_rate

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
    ahead = CsvAhead.of(system.compiled)
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
    monkeypatch.setattr(csvahead, "MAX_AHEAD_BYTES", 1)  # one piece each, then no more
    path = _long(fixture_fmu, write_system, tmp_path)
    result, ahead = _guarded(path)
    assert ahead.rows == 2 * PIECE_ROWS  # the guardian's first piece, the child's last one
    assert sorted(ahead._pieces) == [0, (STEPS // PIECE_ROWS) * PIECE_ROWS]
    plain = fmionnx.load(path).run(isolate="none")
    assert _csv(result, tmp_path / "ahead.csv", ahead) == _csv(plain, tmp_path / "plain.csv")


class _Idle(CsvAhead):
    """Formats nothing while the run goes on: the guarded child's share is then all but the
    first piece, and nothing depends on how fast either process is."""

    def follow(self, published: object) -> bool:  # type: ignore[override]
        return False


def _lone(fixture_fmu, write_system) -> Path:
    """One FMU: the native loop ends long before its rows are formatted."""
    return write_system(
        f"""
fmionnx: 1
name: lone
run: {{stop: {STEPS * 0.01:g}, step: 0.01}}
components:
  integ: {{kind: fmu, path: {fixture_fmu("Integrator")}, parameters: {{u: 0.3}}}}
"""
    )


def test_the_child_formats_its_share_from_the_end(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    path = _lone(fixture_fmu, write_system)
    system = fmionnx.load(path)
    ahead = _Idle.of(system.compiled)
    result = run_guarded(system.compiled, system.run, RunOptions(), follower=ahead)
    assert result.status is RunStatus.COMPLETED
    assert result.details["native_loop"] is True
    last = STEPS // PIECE_ROWS * PIECE_ROWS  # the last piece's first row (the table has STEPS + 1)
    assert sorted(ahead._pieces) == list(range(PIECE_ROWS, last + 1, PIECE_ROWS))
    plain = fmionnx.load(path).run(isolate="none")
    assert _csv(result, tmp_path / "shared.csv", ahead) == _csv(plain, tmp_path / "plain.csv")


def test_the_childs_share_stops_at_the_front(fixture_fmu, write_system) -> None:
    path = _lone(fixture_fmu, write_system)
    system = fmionnx.load(path)
    result = system.run(isolate="none")
    ahead = CsvAhead.of(system.compiled)
    last = STEPS // PIECE_ROWS * PIECE_ROWS
    firsts = [first for first, _, _ in ahead.tail(result, lambda: 3 * PIECE_ROWS)]
    assert firsts == list(range(last, 3 * PIECE_ROWS, -PIECE_ROWS))
    whole = [first for first, _, _ in ahead.tail(result, lambda: 0)]
    assert whole == list(range(last, 0, -PIECE_ROWS))  # all but the guardian's first piece
    fronts = iter(range(0, last, PIECE_ROWS // 2))  # the front moves on meanwhile: they meet
    met = [first for first, _, _ in ahead.tail(result, lambda: next(fronts))]
    assert met == whole[:6]
    assert list(ahead.tail(result, lambda: int(guardian._NO_SHARE))) == []  # a stop request


def test_a_share_that_is_not_the_results_is_not_used(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    path = _lone(fixture_fmu, write_system)
    system = fmionnx.load(path)
    result = system.run(isolate="none")
    ahead = CsvAhead.of(system.compiled)
    pieces = list(ahead.tail(result, lambda: 0))
    forged = [(first, values + 1.0, text) for first, values, text in pieces]  # other numbers
    misplaced = [(first + 1, values, text) for first, values, text in pieces]  # off the grid
    ahead.adopt([*forged, *misplaced])
    assert ahead._pieces  # adopted, but their values are not the table's
    expected = _csv(result, tmp_path / "plain.csv")
    assert _csv(result, tmp_path / "forged.csv", ahead) == expected
    assert ahead.text(np.column_stack([result.time, *result.signals.values()]), PIECE_ROWS) is None


@pytest.mark.parametrize(
    "placed",
    [
        "not a list",
        [(0, 1, 1, 0, 1)],  # inside the control block
        [(0, 1, 1, 1 << 40, 1)],  # beyond the file
        [(0, -1, 1, guardian.CONTROL, 1)],
        [(0, 1, 1, guardian.CONTROL, 1, 9)],
        [(True, 1, 1, guardian.CONTROL, 1)],
    ],
)
def test_where_the_child_says_its_share_is_checked(placed: object) -> None:
    shared = guardian._Shared()
    adopted: list[object] = []

    class Recording(_Idle):
        def adopt(self, pieces) -> None:  # type: ignore[no-untyped-def]
            adopted.append(pieces)

    try:
        guardian._adopt(Recording.__new__(Recording), shared, placed)
    finally:
        shared.close()
    assert adopted == []


def test_a_share_that_cannot_be_read_back_costs_nothing_but_time(
    fixture_fmu, write_system, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*_: object) -> None:
        raise OSError("the shared file could not be mapped")

    monkeypatch.setattr(guardian, "_adopt", broken)
    path = _lone(fixture_fmu, write_system)
    system = fmionnx.load(path)
    ahead = _Idle.of(system.compiled)
    result = run_guarded(system.compiled, system.run, RunOptions(), follower=ahead)
    assert result.status is RunStatus.COMPLETED
    assert not ahead._pieces  # nothing adopted; the file is formatted here
    plain = fmionnx.load(path).run(isolate="none")
    assert _csv(result, tmp_path / "guarded.csv", ahead) == _csv(plain, tmp_path / "plain.csv")
