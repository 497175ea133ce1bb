"""Single models as systems: ``fmionnx run model.fmu``, ``fmionnx validate model.fmu`` and
``fmionnx.load("model.onnx")``.

A lone model file becomes a one-component system, compiled by :mod:`fmionnx.compile.lone`
into the same system the one-component system file would give (without loading the
system-file types), so every check and the runtime apply unchanged. Diagnostics about the model
point at the whole file (``model.fmu: error[...]``): a line and column of a zip or a protobuf
mean nothing, and a model that cannot be read reports only that, not the run settings it
would have given.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Literal

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Span
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.core.steps import step_problem, time_flags_problem
from fmionnx.core.types import ComponentInterface
from fmionnx.spec.runspec import RunSpec

#: Lone-model warnings not worth showing: unconnected inputs and no connections are the
#: normal state of a model outside a system.
_LONE_MODEL_WARNINGS = (codes.UNCONNECTED_INPUT, codes.ISOLATED_COMPONENT)


def _component_name(path: Path) -> str:
    name = re.sub(r"\W", "_", path.stem) or "model"
    return name if re.match(r"[A-Za-z_]", name) else f"m_{name}"


def compile_single_model(
    path: Path,
    bag: DiagnosticBag,
    *,
    interface: Literal["cs", "me"] | None = None,
    step: float | None = None,
    start: float | None = None,
    stop: float | None = None,
) -> CompiledSystem | None:
    """Compile a one-component system around ``path`` (an FMU or ONNX model) to run it.

    An FMU runs from its default experiment (``step``/``interface`` override); an ONNX model
    gets a one-step run of length 1 s, since it has no time of its own.
    """
    problem = time_flags_problem(start, step, stop)
    if problem is not None:  # checked here: RunSpec would raise a bare ValidationError
        bag.emit(codes.RUN_SETTINGS, problem, Span(path))
        return None
    from fmionnx.kinds.base import TIMELESS
    from fmionnx.kinds.registry import kind_for_path

    kind = kind_for_path(path)  # each kind's module is imported only for its model
    assert kind is not None, path  # callers pass a model file a kind reads
    entry: dict[str, object] = {"path": str(path.resolve())}
    if interface is not None:
        entry["interface"] = interface
    spec: ComponentSpecBase = kind.spec_model.model_validate(entry)
    if TIMELESS in kind.capabilities:  # one step of 1 s: a model without time of its own
        run = RunSpec(start=0.0, stop=1.0, step=1.0)
    else:
        run = RunSpec(step=step, start=start or 0.0, stop=stop)
    if _read_alone(path, spec, bag) is None:
        return None
    return _compile_alone(path, spec, run, bag)


def check_single_model(path: Path, bag: DiagnosticBag) -> CompiledSystem | None:
    """``fmionnx validate MODEL``: compile the model alone, then the kind's deeper checks.

    Any model a kind reads (FMU, ONNX model, MuJoCo scene, signal table) is compiled as
    ``run`` would compile it, under run settings that cannot fail: one step of the model's
    own step (its default experiment's, a scene's physics timestep, else 1 s). Whether the
    model is valid does not depend on an experiment it does not declare. Then the kind's
    ``validate_model`` (FMPy's validation, the ONNX checker) adds what only a lone model's
    validation pays for.
    """
    from fmionnx.kinds.registry import COMPONENT_KINDS, kind_for_path

    kind = kind_for_path(path)
    if kind is None:
        suffixes = sorted({s for k in COMPONENT_KINDS.values() for s in k.suffixes})
        bag.emit(
            codes.UNSUPPORTED_MODEL,
            f"`{path.name}` is not a model fmionnx reads",
            Span(path),
            hint="models end in " + ", ".join(f"`{s}`" for s in suffixes),
        )
        return None
    spec = kind.spec_model.model_validate({"path": str(path.resolve())})
    interface = _read_alone(path, spec, bag)
    if interface is None:
        return None
    step = _own_step(interface)
    compiled = _compile_alone(path, spec, RunSpec(start=0.0, stop=step, step=step), bag)
    for problem in kind.validate_model(path, interface):
        bag.emit(problem.code, problem.message, Span(path), hint=problem.hint)
    return compiled


def _own_step(interface: ComponentInterface) -> float:
    """The model's own step: default experiment, else physics timestep, else 1 s."""
    experiment = interface.default_experiment
    if (
        experiment is not None
        and experiment.step is not None
        and step_problem(experiment.step) is None
    ):
        return experiment.step
    timestep = interface.fact("timestep")
    if timestep is not None:
        try:
            value = float(timestep)
        except ValueError:
            value = 0.0
        if step_problem(value) is None:
            return value
    return 1.0


def _read_alone(
    path: Path, spec: ComponentSpecBase, bag: DiagnosticBag
) -> ComponentInterface | None:
    """The model's interface; when it cannot be read, its errors (whole-file spans) only."""
    from fmionnx.compile.resolve import read_interface
    from fmionnx.spec.sourcemap import SourceMap

    scratch = DiagnosticBag()
    interface = read_interface(_component_name(path), spec, path, SourceMap(path), scratch)
    if interface is None:  # the kind's other checks are reported by the compile that follows
        bag.extend(_whole_file(d, path) for d in scratch)
    return interface


def _compile_alone(
    path: Path, spec: ComponentSpecBase, run: RunSpec, bag: DiagnosticBag
) -> CompiledSystem | None:
    """The one-component system, compiled without the system-file types (:mod:`.lone`)."""
    from fmionnx.compile.lone import compile_lone

    scratch = DiagnosticBag()
    compiled = compile_lone(_component_name(path), spec, run, path, scratch)
    bag.extend(
        _whole_file(d, path)
        for d in scratch
        if d.code not in {c.code for c in _LONE_MODEL_WARNINGS}
    )
    return compiled


def _whole_file(diagnostic: Diagnostic, path: Path) -> Diagnostic:
    """The diagnostic pointing at the model file as a whole (no line of a binary file).

    The ``component `name`:`` prefix goes too: the user named a file, not a component.
    """
    span = diagnostic.span
    if span is None or span.file != path:
        return diagnostic
    message = diagnostic.message.removeprefix(f"component `{_component_name(path)}`: ")
    return dataclasses.replace(diagnostic, span=Span(path), message=message)
