"""Checks as the compiled system holds them: resolved, typed expression trees.

A check is one comparison, ``measure <op> bound``: the measure is a scalar computed from the
recorded signals (the same tree serves a parameter sweep as a metric), the bound a number.
The compiler (:mod:`fmionnx.compile.checks`) has already resolved every name: a signal is
its results column and port, a site or an expected path is its coordinates. So the tree
needs neither the system file nor the models to be evaluated (a ROS 2 supervisor or a sweep
worker on another host evaluates it from the results alone), and it is written to and read
from the compiled-system file like the rest of the IR.

Every node type has field names of its own, so the compiled-system codec tells the members
of :data:`Expr` apart by their fields.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from fmionnx.core.diagnostics import Span
from fmionnx.core.types import PortRef

#: How a check compares its measure with its bound.
Comparison = Literal["<", "<=", ">", ">=", "==", "!="]
#: Operators between two values (arithmetic, comparison within a condition, logic).
BinaryOperator = Literal["+", "-", "*", "/", "<", "<=", ">", ">=", "==", "!=", "and", "or"]
#: Functions of one value applied to every sample (or to a number).
UnaryOperator = Literal["-", "not", "abs"]
#: Functions that reduce a signal over the run to one number.
Reduction = Literal["final", "initial", "min", "max", "mean", "first_time"]

#: The column name of the time axis (``time`` in an expression).
TIME = "time"


@dataclass(frozen=True, slots=True)
class Number:
    """A constant."""

    value: float


@dataclass(frozen=True, slots=True)
class Signal:
    """A recorded signal: its ``results.csv`` column and the port it reads (None: ``time``)."""

    column: str
    ref: PortRef | None = None


@dataclass(frozen=True, slots=True)
class Unary:
    """``-x``, ``not c`` or ``abs(x)``, sample by sample."""

    unary: UnaryOperator
    operand: Expr


@dataclass(frozen=True, slots=True)
class Binary:
    """``left <op> right``, sample by sample (a number applies to every sample)."""

    binary: BinaryOperator
    left: Expr
    right: Expr


@dataclass(frozen=True, slots=True)
class Reduce:
    """A signal (or a condition, for ``first_time``) reduced to one number."""

    reduce: Reduction
    series: Expr


@dataclass(frozen=True, slots=True)
class Distance:
    """Euclidean distance of the point ``coordinates`` (2 or 3 signals) to a fixed point."""

    coordinates: tuple[Expr, ...]
    to: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class Deviation:
    """Distance of the point ``coordinates`` to the nearest point of a polyline."""

    coordinates: tuple[Expr, ...]
    path: tuple[tuple[float, ...], ...]


#: Any node of a check expression.
Expr = Number | Signal | Unary | Binary | Reduce | Distance | Deviation


@dataclass(frozen=True, slots=True)
class Check:
    """One statement about a run's results, resolved.

    ``expression`` is the text as written (whitespace runs folded), ``refs`` the ports the
    measure reads: the runtime records them whatever the ``record`` list says.
    """

    name: str
    expression: str
    measure: Expr
    comparison: Comparison
    bound: float
    refs: tuple[PortRef, ...] = ()
    span: Span | None = None


def signals_of(expr: Expr) -> tuple[Signal, ...]:
    """Every signal ``expr`` reads, in reading order (repeats kept)."""
    match expr:
        case Signal():
            return (expr,)
        case Number():
            return ()
        case Unary(operand=operand):
            return signals_of(operand)
        case Binary(left=left, right=right):
            return signals_of(left) + signals_of(right)
        case Reduce(series=series):
            return signals_of(series)
        case Distance(coordinates=coordinates) | Deviation(coordinates=coordinates):
            return tuple(s for c in coordinates for s in signals_of(c))
    msg = f"not a check expression node: {expr!r}"
    raise TypeError(msg)
