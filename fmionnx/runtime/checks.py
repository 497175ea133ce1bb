"""Evaluating checks over a run's recorded signals (numpy, nothing re-run).

The compiled tree (:mod:`fmionnx.compile.checkir`) is walked once per check: signals are
the result's columns at every base step, numbers broadcast over them, reductions make one
number. :func:`measure` is the value alone (a sweep's metric); :func:`evaluate_checks`
compares it with the bound. A check whose measure cannot be computed -- a signal that was not
recorded, a condition that never holds, a value that is not a number -- fails, with a note
that says why, and never raises.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

import fmionnx.compile.checkir as ir
from fmionnx.runtime.result import RunResult, RunStatus

#: A value while evaluating: one number, or one number (or truth) per recorded step.
Value = float | npt.NDArray[Any]


class MeasureError(Exception):
    """A measure that has no value for this run; the message says why (one phrase)."""


@dataclass(frozen=True, slots=True)
class CheckOutcome:
    """One check's verdict: the measured ``value`` (None when there is none), the bound and
    whether it held; ``note`` says why a check without a value failed, or that the run did not
    complete (the value covers only what was recorded)."""

    name: str
    expression: str
    value: float | None
    comparison: str
    bound: float
    passed: bool
    note: str | None = None

    def as_json(self) -> dict[str, object]:
        """The run.json entry (a value that is not a finite number is written as null)."""
        value = self.value if self.value is not None and math.isfinite(self.value) else None
        return {
            "name": self.name,
            "expression": self.expression,
            "value": value,
            "bound": self.bound,
            "passed": self.passed,
            "note": self.note,
        }


_COMPARE: dict[str, Callable[[Any, Any], Any]] = {
    "<": np.less,
    "<=": np.less_equal,
    ">": np.greater,
    ">=": np.greater_equal,
    "==": np.equal,
    "!=": np.not_equal,
}
_ARITHMETIC: dict[str, Callable[[Any, Any], Any]] = {
    "+": np.add,
    "-": np.subtract,
    "*": np.multiply,
    "/": np.divide,
    "and": np.logical_and,
    "or": np.logical_or,
}
_REDUCE: dict[str, Callable[[npt.NDArray[Any]], Any]] = {
    "final": lambda series: series[-1],
    "initial": lambda series: series[0],
    "min": np.min,
    "max": np.max,
    "mean": np.mean,
}


def evaluate_checks(checks: tuple[ir.Check, ...], result: RunResult) -> tuple[CheckOutcome, ...]:
    """The verdict of every check on ``result``, in the order the system file lists them."""
    partial = None
    if result.status is not RunStatus.COMPLETED:
        partial = f"the run did not complete ({result.status.value}): measured on what was recorded"
    outcomes = []
    for check in checks:
        try:
            value = measure(check.measure, result)
        except MeasureError as exc:
            outcomes.append(
                CheckOutcome(
                    check.name, check.expression, None, check.comparison, check.bound, False,
                    str(exc),
                )
            )  # fmt: skip
            continue
        passed = bool(_COMPARE[check.comparison](value, check.bound))
        note = partial
        if math.isnan(value):
            note = "the measure is not a number"
        outcomes.append(
            CheckOutcome(
                check.name, check.expression, value, check.comparison, check.bound, passed, note
            )
        )
    return tuple(outcomes)


def measure(expr: ir.Expr, result: RunResult) -> float:
    """The value of a measure (a number-typed expression) on ``result``; MeasureError if none."""
    with np.errstate(all="ignore"):  # x/0 is inf, 0/0 nan: reported, not warned about
        value = _value(expr, result)
    if isinstance(value, np.ndarray):
        msg = "the measure is a signal, not a number"  # the compiler refuses such a tree
        raise MeasureError(msg)
    return float(value)


def _value(expr: ir.Expr, result: RunResult) -> Value:
    match expr:
        case ir.Number(value=value):
            return value
        case ir.Signal(column=column):
            return _column(column, result)
        case ir.Unary(unary=unary, operand=operand):
            inner = _value(operand, result)
            if unary == "-":
                return np.negative(inner)
            if unary == "not":
                return np.logical_not(inner)
            return np.abs(inner)
        case ir.Binary(binary=binary, left=left, right=right):
            function = _COMPARE.get(binary) or _ARITHMETIC[binary]
            return function(_value(left, result), _value(right, result))  # type: ignore[no-any-return]
        case ir.Reduce(reduce=reduction, series=series):
            values = np.atleast_1d(_value(series, result))
            if reduction == "first_time":
                return _first_time(values, result)
            return float(_REDUCE[reduction](values))
        case ir.Distance(coordinates=coordinates, to=target):
            points = _points(coordinates, result)
            return np.asarray(np.linalg.norm(points - np.asarray(target), axis=1))
        case ir.Deviation(coordinates=coordinates, path=path):
            return distance_to_polyline(_points(coordinates, result), np.asarray(path))
    msg = f"not a check expression node: {expr!r}"
    raise TypeError(msg)


def _column(column: str, result: RunResult) -> npt.NDArray[np.float64]:
    if column == ir.TIME:
        values = result.time
    elif column in result.signals:
        values = result.signals[column]
    else:
        msg = f"`{column}` was not recorded"
        raise MeasureError(msg)
    if len(values) == 0:
        msg = f"`{column}` has no recorded value"
        raise MeasureError(msg)
    # A 64-bit integer signal is recorded exactly (int64/uint64 arrays): measured as floats,
    # as every other signal is, or `a - b` of unsigned values wrapped around to 1.8e19.
    return np.asarray(values, dtype=np.float64)


def _first_time(condition: npt.NDArray[Any], result: RunResult) -> float:
    hits = np.flatnonzero(condition)
    if len(hits) == 0:
        msg = "the condition never holds"
        raise MeasureError(msg)
    return float(result.time[min(int(hits[0]), len(result.time) - 1)])


def _points(coordinates: tuple[ir.Expr, ...], result: RunResult) -> npt.NDArray[np.float64]:
    columns = [np.asarray(_value(c, result), dtype=np.float64) for c in coordinates]
    return np.column_stack(np.broadcast_arrays(*columns))


def distance_to_polyline(
    points: npt.NDArray[np.float64], path: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Shortest distance of each point (rows) to the polyline through ``path``'s rows."""
    best = np.full(len(points), np.inf)
    for a, b in itertools.pairwise(path):
        segment = b - a
        length = float(segment @ segment)
        if length == 0.0:  # a repeated point: the distance to the point itself
            nearest = np.broadcast_to(a, points.shape)
        else:
            s = np.clip(((points - a) @ segment) / length, 0.0, 1.0)
            nearest = a + s[:, None] * segment
        best = np.minimum(best, np.linalg.norm(points - nearest, axis=1))
    return best
