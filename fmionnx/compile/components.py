"""One component entry of a system -> its compiled :class:`~fmionnx.core.types.Component`.

Shared by the compiler of system files (:mod:`fmionnx.compile.compiler`) and the compiler of
a lone model (:mod:`fmionnx.compile.lone`), so that a model run alone becomes the same
component as the same model in a one-component system file.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.compile.ir import RunSettings
from fmionnx.compile.resolve import entry_path, resolve_parameters
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.core.steps import count_problem
from fmionnx.core.types import Component, ComponentInterface, is_whole_multiple
from fmionnx.kinds.base import SIMULATOR
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.sourcemap import SourceMap


def compile_component(
    name: str,
    spec: ComponentSpecBase,
    interface: ComponentInterface,
    run: RunSettings | None,
    system_file: Path,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> Component:
    """The component of entry ``name`` (its model's ``interface`` read) under ``run``.

    Its parameters are resolved against the interface and its period checked against the
    base step (problems go to ``bag``); without run settings (they had errors) the period
    stays as declared.
    """
    parameters = resolve_parameters(name, spec, interface, sources, bag)
    period = spec.period if spec.period is not None else None
    steps = 1
    if run is not None:
        period = period if period is not None else run.step
        steps_or_none = _check_period(name, period, run.step, interface, sources, bag)
        steps = steps_or_none or 1
    return Component(
        name=name,
        kind=spec.kind,
        path=entry_path(system_file, spec),
        interface=interface,
        config=COMPONENT_KINDS[spec.kind].resolve(spec, interface),
        period=period if period is not None else 0.0,
        period_steps=steps,
        parameters=parameters,
        span=sources.key(("components", name)),
        external=spec.external,
        declared_path=spec.path,
    )


def _check_period(
    name: str,
    period: float,
    step: float,
    interface: ComponentInterface,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> int | None:
    span = sources.value(("components", name, "period"))
    problem = count_problem(period, step, f"component `{name}`: period {period}")
    if problem is not None:
        bag.emit(codes.PERIOD, problem, span, hint="a period is at most the length of the run")
        return None
    steps = is_whole_multiple(period, step)
    if steps is None:
        bag.emit(
            codes.PERIOD,
            f"component `{name}`: period {period} is not a whole multiple of the base step {step}",
            span,
            hint=f"use e.g. {max(1, round(period / step)) * step:g}",
        )
        return None
    timestep = interface.fact("timestep")
    if SIMULATOR in COMPONENT_KINDS[interface.kind].capabilities and timestep is not None:
        physics = float(timestep)
        if is_whole_multiple(period, physics) is None:
            bag.emit(
                codes.PERIOD,
                f"component `{name}`: period {period} is not a whole multiple of the scene's "
                f"physics timestep {physics}",
                span,
                hint="change the period or the scene's `<option timestep=...>`",
            )
            return None
    return steps
