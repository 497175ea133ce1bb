"""Single models as systems: ``fmionnx run model.fmu`` and ``fmionnx.load("model.onnx")``.

A lone FMU or ONNX file becomes a one-component system compiled like any other (an in-memory
system file), so every check and the runtime apply unchanged.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.steps import step_problem


def _component_name(path: Path) -> str:
    name = re.sub(r"\W", "_", path.stem) or "model"
    return name if re.match(r"[A-Za-z_]", name) else f"m_{name}"


def compile_single_model(
    path: Path,
    bag: DiagnosticBag,
    *,
    interface: Literal["cs", "me"] | None = None,
    step: float | None = None,
) -> CompiledSystem | None:
    """Compile a one-component system around ``path`` (an in-memory system file).

    An FMU runs from its default experiment (``step``/``interface`` override); an ONNX model
    gets a one-step run of length 1 s, since it has no time of its own.
    """
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.kinds.fmu.kind import FmuSpec
    from fmionnx.kinds.onnx.kind import OnnxSpec
    from fmionnx.spec.model import RunSpec, SystemSpec
    from fmionnx.spec.sourcemap import SourceMap
    from fmionnx.spec.yaml import LoadedSpec

    problem = step_problem(step) if step is not None else None
    if problem is not None:  # checked here: RunSpec would raise a bare ValidationError
        bag.emit("E040", f"--step {problem}", Span(path))
        return None
    absolute = path.resolve()
    name = _component_name(path)
    if path.suffix.lower() == ".onnx":
        spec = SystemSpec(
            fmionnx=1,
            name=name,
            run=RunSpec(start=0.0, stop=1.0, step=1.0),
            components={name: OnnxSpec(path=str(absolute))},
        )
    else:
        spec = SystemSpec(
            fmionnx=1,
            name=name,
            run=RunSpec(step=step),
            components={name: FmuSpec(path=str(absolute), interface=interface)},
        )
    scratch = DiagnosticBag()
    compiled = compile_spec(LoadedSpec(spec, SourceMap(path), path), scratch)
    # an unconnected input is the normal case for a lone model: not worth a warning
    bag.extend(d for d in scratch if d.code not in ("W030", "W050"))
    return compiled
