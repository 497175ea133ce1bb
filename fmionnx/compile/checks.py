"""The compiler's ``checks:`` stage: parse each expression, resolve its names, check its types.

Everything a check names is settled here, with a diagnostic at the character it concerns
(E090 syntax, E091 signal, E092 site or path, E093 meaning, E094 duplicate name): signals
become results columns and ports (which the runtime then records), ``world.site.B`` becomes
the site's coordinates through the component's kind, ``world.expected_path`` the points of
its path file. The result is the closed IR of :mod:`fmionnx.compile.checkir`.

Values have one of four types: a number (a constant or a reduction), a signal (a value at
every recorded step), a condition (a yes/no at every step) and a truth (one yes/no). A check
is ``number <comparison> constant``; docs/checks.md has the rules.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import fmionnx.compile.checkir as ir
from fmionnx.compile.checkparse import (
    COMPARISONS,
    Argument,
    BinaryOp,
    Call,
    Group,
    Name,
    Node,
    NumberLit,
    ParseError,
    UnaryOp,
    parse,
)
from fmionnx.compile.endpoints import endpoint_text, resolve_endpoint, split_endpoint
from fmionnx.compile.expected_path import (
    EXPECTED_PATH,
    PathFileError,
    expected_path_file,
    read_expected_path,
)
from fmionnx.compile.scalarpos import position_in_value
from fmionnx.core import codes
from fmionnx.core.codes import ErrorCode
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span, did_you_mean, one_of
from fmionnx.core.errors import ModelError
from fmionnx.core.signals import column_names
from fmionnx.core.types import (
    Causality,
    Component,
    ComponentInterface,
    DType,
    PortRef,
)
from fmionnx.kinds.base import SITES, Site, SiteSource
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.model import CheckSpec
from fmionnx.spec.sourcemap import SourceMap

#: Functions that reduce a signal to one number, with what they return (for messages).
REDUCTIONS = {
    "final": "the last recorded value",
    "initial": "the first recorded value",
    "min": "the smallest value",
    "max": "the largest value",
    "mean": "the mean of the recorded values",
}
#: Every function of the language, with its signature as documented.
FUNCTIONS = {
    **{name: f"{name}(signal)" for name in REDUCTIONS},
    "first_time": "first_time(condition)",
    "abs": "abs(value)",
    "distance": "distance(x, y[, z], to=point)",
    "deviation": "deviation(x, y[, z], from=path)",
}
#: Where a signal is resolved: its messages are re-emitted at the signal's own column.
_NOWHERE = Span(Path())
#: ``component.site.NAME``: a named fixed point of a component's model.
_SITE = re.compile(r"^(?P<component>.+)\.site\.(?P<site>[^.]+)$")


class Type(enum.Enum):
    """What a value of the language is."""

    NUMBER = "a number"
    SIGNAL = "a signal (a value at every step)"
    CONDITION = "a condition (true or false at every step)"
    TRUTH = "a single true or false"


class _CheckError(Exception):
    """Stops resolving one check: ``code`` and message at ``start`` (an offset in the text)."""

    def __init__(self, code: ErrorCode, message: str, start: int, hint: str | None = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.start = start
        self.hint = hint


@dataclass(frozen=True, slots=True)
class _Typed:
    expr: ir.Expr
    type: Type


def compile_checks(
    specs: list[CheckSpec],
    components: Mapping[str, Component],
    sources: SourceMap,
    bag: DiagnosticBag,
    *,
    unreadable: frozenset[str] = frozenset(),
) -> tuple[ir.Check, ...]:
    """Resolve every entry of ``checks:``; problems go into ``bag`` at their place.

    ``unreadable``: declared components whose model could not be read (reported already); a
    check that reads one cannot be resolved and is left out without a further diagnostic.
    """
    checks = []
    first_of: dict[str, Span] = {}
    for index, spec in enumerate(specs):
        text = " ".join(spec.expect.split())
        name = spec.name if spec.name is not None else text
        name_span = sources.value(("checks", index, "name" if spec.name is not None else "expect"))
        if name in first_of:
            bag.emit(
                codes.DUPLICATE_CHECK,
                f"two checks are called `{name}`",
                name_span,
                hint="give every check its own name: run.json and sweeps tell them apart by it",
                notes=[Note("first used here", first_of[name])],
            )
        else:
            first_of[name] = name_span
        value_span = sources.value(("checks", index, "expect"))
        try:
            resolver = _Resolver(components, unreadable)
            checks.append(resolver.check(name, spec.expect, text, value_span))
        except _UnreadableError:
            continue
        except ParseError as exc:
            span = position_in_value(value_span, spec.expect, exc.start)
            bag.emit(codes.CHECK_SYNTAX, f"check `{name}`: {exc.message}", span, hint=exc.hint)
        except _CheckError as exc:
            span = position_in_value(value_span, spec.expect, exc.start)
            bag.emit(exc.code, f"check `{name}`: {exc.message}", span, hint=exc.hint)
    return tuple(checks)


def compile_measure(
    label: str,
    raw: str,
    components: Mapping[str, Component],
    span: Span,
    bag: DiagnosticBag,
) -> tuple[ir.Expr, tuple[PortRef, ...]] | None:
    """A measure alone (a study's metric): the left side of a check, resolved the same way.

    Returns the expression and the ports it reads; None, with the problem in ``bag`` at its
    character (``label`` starts the message, e.g. "metric `error`"), when it does not resolve
    or is not one number.
    """
    try:
        expr = _Resolver(components).measure(raw)
    except ParseError as exc:
        where = position_in_value(span, raw, exc.start)
        bag.emit(codes.CHECK_SYNTAX, f"{label}: {exc.message}", where, hint=exc.hint)
        return None
    except _CheckError as exc:
        where = position_in_value(span, raw, exc.start)
        bag.emit(exc.code, f"{label}: {exc.message}", where, hint=exc.hint)
        return None
    signals = ir.signals_of(expr)
    return expr, tuple(dict.fromkeys(s.ref for s in signals if s.ref is not None))


class _UnreadableError(Exception):
    """The expression names a declared component whose model could not be read."""


class _Resolver:
    """Resolves one expression against the system's components."""

    def __init__(
        self, components: Mapping[str, Component], unreadable: frozenset[str] = frozenset()
    ) -> None:
        self.components = components
        self.unreadable = unreadable
        self.interfaces: dict[str, ComponentInterface | None] = {
            **dict.fromkeys(unreadable),
            **{n: c.interface for n, c in components.items()},
        }

    def check(self, name: str, raw: str, text: str, span: Span) -> ir.Check:
        node = parse(raw)
        if not (isinstance(node, BinaryOp) and node.operator in COMPARISONS):
            typed = self.value(node)
            raise _CheckError(
                codes.CHECK_MEANING,
                f"a check compares a measure with a bound, but this is {typed.type.value}",
                node.start,
                "write e.g. `max(abs(plant.y)) < 1.5`",
            )
        bound = _constant(node.right)
        if bound is None:
            if _constant(node.left) is not None:
                raise _CheckError(
                    codes.CHECK_MEANING,
                    "the bound comes after the comparison, the measure before it",
                    node.start,
                    "swap the sides (and the comparison): `max(plant.y) < 2` rather than "
                    "`2 > max(plant.y)`",
                )
            raise _CheckError(
                codes.CHECK_MEANING,
                "the bound (right of the comparison) must be a number",
                node.right.start,
                "compare the measure with a constant; a difference of two measures can be "
                "the measure: `final(a.x) - final(b.x) < 0.1`",
            )
        measure = self.value(node.left)
        if measure.type is not Type.NUMBER:
            raise _CheckError(
                codes.CHECK_MEANING, _not_a_number(measure.type), node.left.start, _REDUCE_HINT
            )
        signals = ir.signals_of(measure.expr)
        if not signals:
            raise _CheckError(
                codes.CHECK_MEANING,
                "the measure reads no signal: the check would hold or fail whatever the run",
                node.left.start,
                "measure a signal, e.g. `final(plant.y)`",
            )
        refs = tuple(dict.fromkeys(s.ref for s in signals if s.ref is not None))
        comparison = _COMPARISON[node.operator]
        return ir.Check(name, text, measure.expr, comparison, bound, refs, span)

    def measure(self, raw: str) -> ir.Expr:
        """A measure alone: one number that reads at least one signal (a study's metric)."""
        node = parse(raw)
        if isinstance(node, BinaryOp) and node.operator in COMPARISONS:
            raise _CheckError(
                codes.CHECK_MEANING,
                "a metric is a measure (one number), not a comparison",
                node.start,
                "keep the left side: `final(plant.y)` rather than `final(plant.y) < 1`",
            )
        typed = self.value(node)
        if typed.type is not Type.NUMBER:
            raise _CheckError(
                codes.CHECK_MEANING, _not_a_number(typed.type), node.start, _REDUCE_HINT
            )
        if not ir.signals_of(typed.expr):
            raise _CheckError(
                codes.CHECK_MEANING,
                "the measure reads no signal: it would be the same for every case",
                node.start,
                "measure a signal, e.g. `final(plant.y)`",
            )
        return typed.expr

    # -- values --------------------------------------------------------------------------------

    def value(self, node: Node) -> _Typed:
        match node:
            case NumberLit(value=value):
                return _Typed(ir.Number(value), Type.NUMBER)
            case Name():
                return self.name(node)
            case UnaryOp():
                return self.unary(node)
            case BinaryOp():
                return self.binary(node)
            case Call():
                return self.call(node)
            case Group(bracket="("):
                raise _CheckError(
                    codes.CHECK_MEANING,
                    "a point `(x, y)` is only an argument: `distance(..., to=(x, y))`",
                    node.start,
                )
            case Group():
                raise _CheckError(
                    codes.CHECK_MEANING,
                    "a path `[(x, y), ...]` is only an argument: `deviation(..., from=[...])`",
                    node.start,
                )
        msg = f"unknown syntax node {node!r}"
        raise TypeError(msg)

    def name(self, node: Name) -> _Typed:
        if node.text == ir.TIME:
            return _Typed(ir.Signal(ir.TIME), Type.SIGNAL)
        text = node.text.replace("`", "")
        if "." not in text and not node.text.startswith("`"):
            hint = did_you_mean(text, [*FUNCTIONS, ir.TIME])
            raise _CheckError(
                codes.CHECK_SIGNAL,
                f"`{text}` is not a signal: signals are written `component.port`",
                node.start,
                hint or "`time` is the time axis; functions are called with `(...)`",
            )
        return _Typed(self.signal(text, node.start), Type.SIGNAL)

    def signal(self, text: str, start: int) -> ir.Signal:
        scratch = DiagnosticBag()
        resolved = resolve_endpoint(text, _NOWHERE, self.interfaces, scratch)
        if resolved is None:
            self._reference_used_as_signal(text, start)
            found = next(iter(scratch), None)
            if found is None:  # the component's model could not be read: reported already
                raise _UnreadableError(text)
            raise _CheckError(codes.CHECK_SIGNAL, found.message, start, found.hint)
        port, ref = resolved.port, resolved.ref
        where = f"`{ref}`"
        if port.causality not in (Causality.OUTPUT, Causality.INPUT):
            raise _CheckError(
                codes.CHECK_SIGNAL,
                f"{where} is a {port.causality.value}; checks read outputs and inputs (what is "
                "recorded while the system runs)",
                start,
            )
        if not port.dtype.is_numeric:
            raise _CheckError(
                codes.CHECK_SIGNAL,
                f"{where} is a {port.dtype.value}; checks measure numbers",
                start,
            )
        if ref.index is None and not port.is_scalar:
            raise _CheckError(
                codes.CHECK_SIGNAL,
                f"{where} is an array of shape {port.shape_text()}; a check reads one element",
                start,
                _pick_an_element(ref),
            )
        if ref.index is not None and len(port.shape) >= 2 and port.dtype is DType.UINT8:
            raise _CheckError(
                codes.CHECK_SIGNAL, f"{where} is an image: images are not recorded", start
            )
        # the column results.csv gives the element (``power[0]`` and ``power[0,0]`` are one)
        column = str(ref) if ref.index is None else column_names(ref.component, port, ref.index)[0]
        return ir.Signal(column, ref)

    def _reference_used_as_signal(self, text: str, start: int) -> None:
        parts = split_endpoint(text, self.interfaces)
        if parts is None or parts[0] not in self.components:
            return
        if parts[1] == EXPECTED_PATH:
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{text}` is a path: it is the `from=` of `deviation(x, y, from={text})`",
                start,
            )
        if _SITE.match(text):
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{text}` is a point: it is the `to=` of `distance(x, y, to={text})`",
                start,
            )

    def unary(self, node: UnaryOp) -> _Typed:
        operand = self.value(node.operand)
        if node.operator == "not":
            if operand.type not in (Type.CONDITION, Type.TRUTH):
                raise _CheckError(
                    codes.CHECK_MEANING,
                    f"`not` needs a condition, not {operand.type.value}",
                    node.start,
                )
            return _Typed(ir.Unary("not", operand.expr), operand.type)
        _numeric(operand, node.operator, node.start)
        if node.operator == "+":
            return operand
        if isinstance(operand.expr, ir.Number):
            return _Typed(ir.Number(-operand.expr.value), Type.NUMBER)
        return _Typed(ir.Unary("-", operand.expr), operand.type)

    def binary(self, node: BinaryOp) -> _Typed:
        left, right = self.value(node.left), self.value(node.right)
        operator = node.operator
        if operator in ("and", "or"):
            for side in (left, right):
                if side.type not in (Type.CONDITION, Type.TRUTH):
                    raise _CheckError(
                        codes.CHECK_MEANING,
                        f"`{operator}` joins conditions, not {side.type.value}",
                        node.at,
                        "compare first: `a.x > 1 and a.y < 2`",
                    )
            over_time = Type.CONDITION in (left.type, right.type)
            return _Typed(
                ir.Binary(_BINARY[operator], left.expr, right.expr),
                Type.CONDITION if over_time else Type.TRUTH,
            )
        _numeric(left, operator, node.at)
        _numeric(right, operator, node.at)
        over_time = Type.SIGNAL in (left.type, right.type)
        if operator in COMPARISONS:
            result = Type.CONDITION if over_time else Type.TRUTH
        else:
            result = Type.SIGNAL if over_time else Type.NUMBER
        return _Typed(ir.Binary(_BINARY[operator], left.expr, right.expr), result)

    # -- functions -----------------------------------------------------------------------------

    def call(self, node: Call) -> _Typed:
        function = node.function
        if function not in FUNCTIONS:
            hint = did_you_mean(function, FUNCTIONS) or one_of(FUNCTIONS)
            raise _CheckError(
                codes.CHECK_SYNTAX, f"unknown function `{function}`", node.start, hint
            )
        if function in ("distance", "deviation"):
            return self.geometry(node)
        argument = _single(node, FUNCTIONS[function])
        value = self.value(argument.value)
        if function == "abs":
            _numeric(value, "abs", argument.start)
            if isinstance(value.expr, ir.Number):
                return _Typed(ir.Number(abs(value.expr.value)), Type.NUMBER)
            return _Typed(ir.Unary("abs", value.expr), value.type)
        if function == "first_time":
            if value.type is not Type.CONDITION:
                raise _CheckError(
                    codes.CHECK_MEANING,
                    f"`first_time` takes a condition, not {value.type.value}",
                    argument.start,
                    "write e.g. `first_time(plant.y > 1.0)`",
                )
            return _Typed(ir.Reduce("first_time", value.expr), Type.NUMBER)
        if value.type is not Type.SIGNAL:
            hint = "for a condition, `first_time(...)` gives when it first holds"
            if value.type is Type.NUMBER:
                hint = f"`{function}` already has one number: drop it"
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{function}` takes a signal, not {value.type.value}",
                argument.start,
                hint,
            )
        reduction = _REDUCTION[function]
        return _Typed(ir.Reduce(reduction, value.expr), Type.NUMBER)

    def geometry(self, node: Call) -> _Typed:
        function = node.function
        keyword = "to" if function == "distance" else "from"
        positional = [a for a in node.arguments if a.keyword is None]
        named = {}
        for argument in node.arguments:
            if argument.keyword is None:
                continue
            if argument.keyword != keyword:
                raise _CheckError(
                    codes.CHECK_MEANING,
                    f"`{function}` has no argument `{argument.keyword}`",
                    argument.start,
                    f"write `{FUNCTIONS[function]}`",
                )
            if argument.keyword in named:
                raise _CheckError(
                    codes.CHECK_MEANING, f"`{keyword}=` is given twice", argument.start
                )
            named[argument.keyword] = argument
        if not 2 <= len(positional) <= 3:
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{function}` takes 2 or 3 coordinates (x, y[, z]), not {len(positional)}",
                node.start,
                f"write `{FUNCTIONS[function]}`",
            )
        if keyword not in named:
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{function}` needs `{keyword}=`",
                node.start,
                f"write `{FUNCTIONS[function]}`",
            )
        coordinates = []
        for argument in positional:
            value = self.value(argument.value)
            if value.type is not Type.SIGNAL:
                raise _CheckError(
                    codes.CHECK_MEANING,
                    f"a coordinate of `{function}` is a signal, not {value.type.value}",
                    argument.start,
                )
            coordinates.append(value.expr)
        target = named[keyword]
        dimensions = len(coordinates)
        if function == "distance":
            point = self.point(target.value, dimensions)
            return _Typed(ir.Distance(tuple(coordinates), point), Type.SIGNAL)
        path = self.path(target.value, dimensions)
        return _Typed(ir.Deviation(tuple(coordinates), path), Type.SIGNAL)

    def point(self, node: Node, dimensions: int) -> tuple[float, ...]:
        if isinstance(node, Group) and node.bracket == "(":
            point = _numbers(node, "a point")
            if len(point) != dimensions:
                raise _CheckError(
                    codes.CHECK_MEANING,
                    f"the point has {len(point)} coordinates, the measured position {dimensions}",
                    node.start,
                )
            return point
        if isinstance(node, Name):
            position = self.site(node)
            return position[:dimensions]
        raise _CheckError(
            codes.CHECK_MEANING,
            "`to=` is a fixed point: `(x, y)`, `(x, y, z)` or a site `component.site.NAME`",
            node.start,
        )

    def site(self, node: Name) -> tuple[float, float, float]:
        match = _SITE.match(node.text)
        if match is None:
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"`{node.text}` is not a site: write `component.site.NAME` or a point `(x, y)`",
                node.start,
            )
        name, site_name = match.group("component"), match.group("site")
        component = self._component(name, node.start)
        kind = COMPONENT_KINDS[component.kind]
        if SITES not in kind.capabilities or not isinstance(kind, SiteSource):
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"component `{name}` ({component.kind}) has no sites",
                node.start,
                "sites are named points of a simulator's scene; give a point `(x, y)` instead",
            )
        try:
            sites: Mapping[str, Site] = kind.sites(component.path)
        except ModelError as exc:
            raise _CheckError(
                codes.CHECK_REFERENCE, f"the sites of `{name}` cannot be read: {exc}", node.start
            ) from None
        if site_name not in sites:
            hint = did_you_mean(site_name, sites) or (one_of(sites) if sites else None)
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"`{component.path.name}` has no site `{site_name}`",
                node.start,
                hint or "the scene names no site",
            )
        site = sites[site_name]
        if site.moves_with is not None:
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"site `{site_name}` moves with body `{site.moves_with}`; `to=` is a fixed point",
                node.start,
                "measure to a site fixed in the world, or give a point `(x, y)`",
            )
        return site.position

    def path(self, node: Node, dimensions: int) -> tuple[tuple[float, ...], ...]:
        if isinstance(node, Group) and node.bracket == "[":
            points = []
            for item in node.items:
                if not (isinstance(item, Group) and item.bracket == "("):
                    raise _CheckError(
                        codes.CHECK_MEANING,
                        "a path is a list of points `[(x, y), ...]`",
                        item.start,
                    )
                point = _numbers(item, "a point")
                if len(point) != dimensions:
                    raise _CheckError(
                        codes.CHECK_MEANING,
                        f"the point has {len(point)} coordinates, the measured position "
                        f"{dimensions}",
                        item.start,
                    )
                points.append(point)
            if len(points) < 2:
                raise _CheckError(codes.CHECK_MEANING, "a path needs at least 2 points", node.start)
            return tuple(points)
        if isinstance(node, Name):
            return self.expected_path(node, dimensions)
        raise _CheckError(
            codes.CHECK_MEANING,
            "`from=` is a path: `component.expected_path` or a list of points `[(x, y), ...]`",
            node.start,
        )

    def expected_path(self, node: Name, dimensions: int) -> tuple[tuple[float, ...], ...]:
        name, _, last = node.text.rpartition(".")
        if last != EXPECTED_PATH or not name:
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"`{node.text}` is not a path: write `component.{EXPECTED_PATH}` or a list of "
                "points `[(x, y), ...]`",
                node.start,
            )
        component = self._component(name, node.start)
        file = expected_path_file(component.path)
        if not file.is_file():
            raise _CheckError(
                codes.CHECK_REFERENCE,
                f"component `{name}` has no expected path: `{file.name}` is not next to "
                f"`{component.path.name}`",
                node.start,
                "write the path as a CSV with columns `x,y`, or give the points `[(x, y), ...]`",
            )
        if dimensions != 2:
            raise _CheckError(
                codes.CHECK_MEANING,
                f"`{node.text}` is a planar path (x, y); measure 2 coordinates, not {dimensions}",
                node.start,
            )
        try:
            return read_expected_path(file)
        except PathFileError as exc:
            raise _CheckError(codes.CHECK_REFERENCE, str(exc), node.start) from None

    def _component(self, name: str, start: int) -> Component:
        if name in self.unreadable:
            raise _UnreadableError(name)
        if name not in self.components:
            hint = did_you_mean(name, self.components) or one_of(self.components)
            raise _CheckError(codes.CHECK_REFERENCE, f"unknown component `{name}`", start, hint)
        return self.components[name]


_REDUCE_HINT = "reduce it to one number: final(...), min(...), max(...), mean(...), first_time(...)"

_COMPARISON: dict[str, ir.Comparison] = {
    "<": "<", "<=": "<=", ">": ">", ">=": ">=", "==": "==", "!=": "!=",
}  # fmt: skip
_BINARY: dict[str, ir.BinaryOperator] = {
    "+": "+", "-": "-", "*": "*", "/": "/", "and": "and", "or": "or", **_COMPARISON,
}  # fmt: skip
_REDUCTION: dict[str, ir.Reduction] = {
    "final": "final", "initial": "initial", "min": "min", "max": "max", "mean": "mean",
}  # fmt: skip


def _not_a_number(found: Type) -> str:
    if found is Type.SIGNAL:
        return "the measure is a whole signal; a check compares one number with the bound"
    return f"the measure is {found.value}; a check compares one number with the bound"


def _numeric(value: _Typed, operator: str, start: int) -> None:
    if value.type not in (Type.NUMBER, Type.SIGNAL):
        raise _CheckError(
            codes.CHECK_MEANING,
            f"`{operator}` takes numbers or signals, not {value.type.value}",
            start,
        )


def _single(node: Call, signature: str) -> Argument:
    if len(node.arguments) != 1 or node.arguments[0].keyword is not None:
        raise _CheckError(
            codes.CHECK_MEANING,
            f"`{node.function}` takes one argument: `{signature}`",
            node.start,
        )
    return node.arguments[0]


def _constant(node: Node) -> float | None:
    """The value of a number as written (``-0.5`` included), or None."""
    if isinstance(node, NumberLit):
        return node.value
    if isinstance(node, UnaryOp) and node.operator in ("-", "+"):
        inner = _constant(node.operand)
        if inner is not None:
            return -inner if node.operator == "-" else inner
    return None


def _numbers(node: Group, what: str) -> tuple[float, ...]:
    values = []
    for item in node.items:
        value = _constant(item)
        if value is None:
            raise _CheckError(
                codes.CHECK_MEANING, f"the coordinates of {what} are numbers", item.start
            )
        values.append(value)
    if not 2 <= len(values) <= 3:
        raise _CheckError(
            codes.CHECK_MEANING, f"{what} has 2 or 3 coordinates, not {len(values)}", node.start
        )
    return tuple(values)


def _pick_an_element(ref: PortRef) -> str:
    """The hint for an array named whole: its first element as a check names it (a quoted
    port, ``q."x y"``, goes between backticks in an expression)."""
    first = endpoint_text(PortRef(ref.component, ref.port, (0,)))
    if '"' in first:
        return f"pick an element, between backticks: `` `{first}` ``"
    return f"pick an element: `{first}`"
