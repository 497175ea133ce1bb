"""The units of a study's targets and metrics, for the axes and colour bars of its plots.

A target that is a model's parameter or input has the port's declared unit
(``tracker.cruiseSpeed``: m/s). A metric's unit follows from its measure, as far as it is
plain: a signal has its port's unit and ``time`` seconds; ``final``, ``min``, ``max``,
``mean``, ``abs`` and a sum or difference of like units keep it; ``first_time`` is in
seconds; ``distance`` and ``deviation`` are in the unit of their coordinates. Anything else
(a product, a quotient, mixed units, a condition) is left without a unit rather than guessed.
"""

from __future__ import annotations

from fmionnx.compile import checkir as ir
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.studyir import StudyPlan
from fmionnx.core.types import PortRef

#: A plain number in a measure: no unit of its own (``2 * x`` keeps ``x``'s).
_NUMBER = ""


def target_unit(system: CompiledSystem, target: str) -> str | None:
    """The unit of the port ``target`` sets (``component.port``); None when it has none."""
    owners = [c for c in system.components if target.startswith(c.name + ".")]
    if not owners:
        return None
    component = max(owners, key=lambda c: len(c.name))
    port = component.interface.port(target[len(component.name) + 1 :])
    return port.unit if port is not None and port.unit else None


def metric_unit(system: CompiledSystem, measure: ir.Expr) -> str | None:
    """The unit of a metric's value (see the module's docstring); None when not plain."""
    unit = _unit(system, measure)
    return unit or None


def labelled(name: str, unit: str | None) -> str:
    """``time_to_B [s]``: a name with its unit, for an axis or a colour bar."""
    return f"{name} [{unit}]" if unit else name


def plan_units(plan: StudyPlan) -> dict[str, str | None]:
    """Target and metric name -> unit."""
    units = {t: target_unit(plan.system, t) for t in plan.targets}
    units.update({m.name: metric_unit(plan.system, m.measure) for m in plan.metrics})
    return units


def _port_unit(system: CompiledSystem, ref: PortRef) -> str | None:
    port = system.component(ref.component).port(ref.port)
    return port.unit if port.unit else None


def _same(units: list[str | None]) -> str | None:
    """The one unit all of ``units`` share (plain numbers aside); None when they differ."""
    named = {u for u in units if u != _NUMBER}
    if None in named or len(named) > 1:
        return None
    return named.pop() if named else _NUMBER


def _unit(system: CompiledSystem, node: ir.Expr) -> str | None:
    match node:
        case ir.Number():
            return _NUMBER
        case ir.Signal(column=column, ref=ref):
            if ref is None:
                return "s" if column == ir.TIME else None
            return _port_unit(system, ref)
        case ir.Unary(unary=operator, operand=operand):
            return _unit(system, operand) if operator in ("-", "abs") else None
        case ir.Binary(binary=operator, left=left, right=right):
            sides = [_unit(system, left), _unit(system, right)]
            if operator in ("+", "-"):
                return _same(sides)
            if operator in ("*", "/") and _NUMBER in sides:
                other = sides[1] if sides[0] == _NUMBER else sides[0]
                return other if operator == "*" or sides[1] == _NUMBER else None
            return None
        case ir.Reduce(reduce=reduction, series=series):
            return "s" if reduction == "first_time" else _unit(system, series)
        case ir.Distance(coordinates=coordinates) | ir.Deviation(coordinates=coordinates):
            return _same([_unit(system, c) for c in coordinates])
    return None
