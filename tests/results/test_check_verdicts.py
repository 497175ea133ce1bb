"""Every function of the check language measured on known signals, and the verdicts."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from fmionnx import api
from fmionnx.compile.ir import CompiledSystem
from fmionnx.results import write_results
from fmionnx.runtime.checks import CheckOutcome, distance_to_polyline, evaluate_checks
from fmionnx.runtime.result import RunResult, RunStatus

SYSTEM = """\
fmionnx: 1
name: measured
run: {stop: 1, step: 0.1}
components:
  s: {kind: signal, outputs: {x: {constant: 0}, y: {constant: 0}, z: {constant: 0}}}
checks:
"""

TIME = np.arange(11) * 0.1
#: x rises with time from 0 to 1, y falls from 2 to 1: the points lie on the line x + y = 2.
SIGNALS = {"s.x": TIME.copy(), "s.y": 2.0 - TIME, "s.z": np.zeros(11)}


def _result(signals: dict[str, np.ndarray] | None = None, status=RunStatus.COMPLETED) -> RunResult:
    return RunResult(
        system="measured",
        backend="inprocess",
        status=status,
        start=0.0,
        stop=1.0,
        step=0.1,
        steps_done=10,
        wall_time=0.01,
        time=TIME,
        signals=dict(SIGNALS if signals is None else signals),
    )


def _system(tmp_path: Path, *expects: str) -> CompiledSystem:
    entries = "".join(f"  - name: c{i}\n    expect: {e}\n" for i, e in enumerate(expects))
    path = tmp_path / "measured.yaml"
    path.write_text(SYSTEM + entries, encoding="utf-8")
    result = api.compile_system(path)
    assert result.system is not None, [str(d) for d in result.diagnostics]
    return result.system


def _verdict(tmp_path: Path, expect: str, result: RunResult | None = None) -> CheckOutcome:
    system = _system(tmp_path, expect)
    (outcome,) = evaluate_checks(system.checks, result or _result())
    return outcome


@pytest.mark.parametrize(
    ("measure", "value"),
    [
        ("final(s.x)", 1.0),
        ("initial(s.x)", 0.0),
        ("min(s.y)", 1.0),
        ("max(s.y)", 2.0),
        ("mean(s.x)", 0.5),
        ("mean(abs(s.x - 1))", 0.5),
        ("abs(final(s.x) - 3)", 2.0),
        ("final(time)", 1.0),
        ("-initial(s.y) * 2 + 10 / 4", -1.5),
        ("first_time(s.x > 0.45)", 0.5),
        ("first_time(s.x >= 0.2 and not s.y < 1.5)", 0.2),
        ("first_time(s.x > 0.95 or s.y > 1.95)", 0.0),
        ("first_time(s.x == s.z)", 0.0),
        ("first_time(s.y != 2)", 0.1),
        ("first_time(s.x > 0.5 * max(s.x))", 0.6),
        ("final(distance(s.x, s.y, to=(1, 0)))", 1.0),
        ("initial(distance(s.x, s.y, s.z, to=(0, 0, 1)))", math.sqrt(5.0)),
        ("min(distance(s.x, s.y, to=(0.5, 1.5)))", 0.0),
        ("max(deviation(s.x, s.y, from=[(0, 2), (1, 1)]))", 0.0),
        ("max(deviation(s.x, s.y, from=[(0, 0), (5, 0)]))", 2.0),
        ("final(deviation(s.x, s.y, from=[(0, 0), (0, 0), (1, 0)]))", 1.0),
    ],
)
def test_each_function_measures_what_it_says(tmp_path: Path, measure: str, value: float) -> None:
    outcome = _verdict(tmp_path, f"{measure} > -100")
    assert outcome.value == pytest.approx(value, abs=1e-12)
    assert outcome.passed
    assert outcome.note is None


@pytest.mark.parametrize(
    ("comparison", "passed"),
    [("<", False), ("<=", True), (">", False), (">=", True), ("==", True), ("!=", False)],
)
def test_comparisons_against_the_bound(tmp_path: Path, comparison: str, passed: bool) -> None:
    outcome = _verdict(tmp_path, f"final(s.x) {comparison} 1")
    assert (outcome.value, outcome.bound, outcome.comparison) == (1.0, 1.0, comparison)
    assert outcome.passed is passed


def test_a_condition_that_never_holds_fails_with_a_note(tmp_path: Path) -> None:
    outcome = _verdict(tmp_path, "first_time(s.x > 5) > 0")
    assert outcome == CheckOutcome(
        "c0", "first_time(s.x > 5) > 0", None, ">", 0.0, False, "the condition never holds"
    )
    assert outcome.as_json()["value"] is None


def test_a_measure_that_is_not_a_number_fails(tmp_path: Path) -> None:
    outcome = _verdict(tmp_path, "final(s.z / s.z) < 1")
    assert not outcome.passed
    assert outcome.note == "the measure is not a number"
    assert outcome.as_json()["value"] is None
    json.dumps(outcome.as_json(), allow_nan=False)  # run.json stays valid JSON


def test_a_signal_that_was_not_recorded_fails_and_says_which(tmp_path: Path) -> None:
    result = _result({"s.x": TIME})
    outcome = _verdict(tmp_path, "final(distance(s.x, s.y, to=(0, 0))) < 9", result)
    assert not outcome.passed
    assert outcome.note == "`s.y` was not recorded"


def test_an_incomplete_run_is_measured_on_what_was_recorded_and_says_so(tmp_path: Path) -> None:
    outcome = _verdict(tmp_path, "final(s.x) > 0.5", _result(status=RunStatus.FAULT))
    assert outcome.passed
    assert outcome.note is not None
    assert outcome.note.startswith("the run did not complete (fault)")


def test_distance_to_polyline_takes_the_nearest_segment() -> None:
    path = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]])
    points = np.array([[1.0, 0.5], [4.0, 1.0], [-1.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(distance_to_polyline(points, path), [0.5, 1.0, 1.0, 1.0])


def test_run_json_records_every_verdict(tmp_path: Path) -> None:
    system = _system(tmp_path, "final(s.x) > 0.5", "max(s.y) < 1")
    out = tmp_path / "out"
    write_results(_result(), system, out)
    checks = json.loads((out / "run.json").read_text(encoding="utf-8"))["checks"]
    assert checks == [
        {
            "name": "c0",
            "expression": "final(s.x) > 0.5",
            "value": 1.0,
            "bound": 0.5,
            "passed": True,
            "note": None,
        },
        {
            "name": "c1",
            "expression": "max(s.y) < 1",
            "value": 2.0,
            "bound": 1.0,
            "passed": False,
            "note": None,
        },
    ]


def test_64_bit_integer_signals_are_measured_as_floats() -> None:
    """int64/uint64 signals are recorded exactly (as integer arrays): a measure computed on
    them in integer arithmetic wrapped around (`final(a - b)` of unsigned 1 and 5 gave 1.8e19,
    `mean(i + i)` of 2**62 a negative number: a review)."""
    from fmionnx.compile import checkir as ir
    from fmionnx.runtime.checks import measure

    result = _result(
        {
            "s.a": np.arange(1, 12, dtype=np.uint64),
            "s.b": np.full(11, 5, dtype=np.uint64),
            "s.i": np.full(11, 2**62, dtype=np.int64),
        }
    )
    a, b, i = (ir.Signal(name) for name in ("s.a", "s.b", "s.i"))
    assert measure(ir.Reduce("initial", ir.Binary("-", a, b)), result) == -4.0
    assert measure(ir.Reduce("min", ir.Unary("-", a)), result) == -11.0
    assert measure(ir.Reduce("mean", ir.Binary("+", i, i)), result) == 2.0**63
