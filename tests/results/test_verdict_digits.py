"""A check's verdict shows the measured value with the digits that tell it from the bound: a
``mean(time) == 0.5`` failing at 0.5000000000000001 said "measured 0.5, expected == 0.5"."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.cli.checks_report import bound_text, value_text, verdict_text
from fmionnx.runtime.checks import CheckOutcome
from tests.conftest import cli

#: Ten steps of 0.1 s: ``mean(time)`` adds up to 0.5000000000000001, not 0.5.
SYSTEM = """\
fmionnx: 1
name: digits
run: {stop: 1, step: 0.1}
components:
  s: {kind: signal, outputs: {x: {constant: 0}}}
checks:
  - name: meanc
    expect: mean(time) == 0.5
  - name: far
    expect: final(time) > 1234567.5
"""


def test_a_failed_check_in_a_real_run_shows_the_digits_that_make_it_fail(
    write_system: Callable[[str], Path],
) -> None:
    code, output = cli("run", str(write_system(SYSTEM)), "--no-out", "--quiet")
    assert code == 1
    assert "check failed: meanc: measured 0.5000000000000001, expected == 0.5" in output
    assert "check failed: far: measured 1, expected > 1234567.5" in output


def _outcome(value: float | None, comparison: str, bound: float) -> CheckOutcome:
    return CheckOutcome("c", f"m {comparison} {bound}", value, comparison, bound, passed=False)


@pytest.mark.parametrize(
    ("value", "comparison", "bound", "shown"),
    [
        (0.49999999999999994, "==", 0.5, "0.49999999999999994"),  # 4 digits: on the bound
        (0.500012, "<", 0.50001, "0.500012"),  # 4 digits ("0.5"): below the bound, not above
        (3.00012, "==", 3.0, "3.0001"),  # the fewest digits past 4 that leave the bound
        (2.0, "<", 1.0, "2"),  # plainly apart: 4 digits as before
        (0.5, "<", 0.5, "0.5"),  # on the bound: so shown
        (0.123456, "<", 0.1, "0.1235"),
        (math.inf, "<", 1.0, "inf"),
    ],
)
def test_the_measured_value_is_on_the_bounds_side_it_was_measured_on(
    value: float, comparison: str, bound: float, shown: str
) -> None:
    assert value_text(_outcome(value, comparison, bound)) == shown


def test_the_bound_is_shown_as_compared() -> None:
    assert bound_text(_outcome(1.0, ">", 1234567.5)) == "1234567.5"  # :g wrote 1.23457e+06
    assert bound_text(_outcome(1.0, ">", 0.01)) == "0.01"
    assert verdict_text(_outcome(1.0, "==", 1.0000001)) == (
        "measured 1, expected == 1.0000001"  # :g wrote both as 1
    )


def test_a_check_without_a_value_still_says_why() -> None:
    outcome = CheckOutcome("c", "first_time(x > 5) > 0", None, ">", 0.0, False, "never")
    assert verdict_text(outcome) == "never"
    assert value_text(outcome) == "—"
