"""The Python API for running: ``fmionnx.load(path).run(...)`` returns numpy arrays.

    >>> import fmionnx
    >>> system = fmionnx.load("systems/sign_follower.yaml")
    >>> result = system.run(stop_time=5.0)
    >>> result["odometry.posX"][-1], result.status

A single FMU's results are named by variable (``result["x"]``), like ``fmpy simulate``.

``load`` accepts a system file (YAML/SSP) or a single model: an ``.fmu`` becomes a
one-component system run from its default experiment with every output recorded under its
variable name; an ``.onnx`` file gives a system whose ``infer`` runs the model once.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem, Origin, RunSettings
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Severity, did_you_mean, one_of
from fmionnx.core.errors import DiagnosticError, FmionnxError
from fmionnx.core.types import (
    Causality,
    Component,
    DType,
    ParameterValue,
    PortRef,
    Scalar,
    is_whole_multiple,
)
from fmionnx.runtime.result import ProgressCallback, RunOptions, RunResult

#: Single-model files ``load`` accepts besides system files.
MODEL_SUFFIXES = (".fmu", ".onnx")
#: Compiled-system files (:mod:`fmionnx.compile.systemfile`; the same suffix, kept import-free).
COMPILED_SUFFIX = ".fmionnx.json"


class OverrideError(FmionnxError):
    """A command-line override (``--param``, ``--stop-time``) that does not fit the system."""


@dataclass(frozen=True)
class System:
    """A compiled system ready to run; immutable (overrides make a new one)."""

    compiled: CompiledSystem
    diagnostics: tuple[Diagnostic, ...] = ()
    aliases: Mapping[str, str] = field(default_factory=dict)
    record: tuple[PortRef, ...] | None = None

    @property
    def name(self) -> str:
        """The system's name."""
        return self.compiled.name

    def with_overrides(
        self,
        *,
        stop_time: float | None = None,
        params: Mapping[str, Scalar | list[Scalar]] | None = None,
    ) -> System:
        """A new System with a different stop time and/or parameter values."""
        compiled = self.compiled
        if stop_time is not None:
            compiled = override_stop(compiled, stop_time)
        for key, value in (params or {}).items():
            compiled = override_parameter(compiled, key, value)
        return dataclasses.replace(self, compiled=compiled)

    def run(
        self,
        *,
        stop_time: float | None = None,
        params: Mapping[str, Scalar | list[Scalar]] | None = None,
        record: tuple[PortRef, ...] | None = None,
        progress: ProgressCallback | None = None,
        options: RunOptions | None = None,
    ) -> RunResult:
        """Run in-process and return the recorded signals (``result["comp.port"]``)."""
        from fmionnx.backends.inprocess import InProcessBackend

        system = self.with_overrides(stop_time=stop_time, params=params)
        backend = InProcessBackend()
        problems = [d for d in backend.validate(system.compiled) if d.severity is Severity.ERROR]
        if problems:
            raise DiagnosticError(problems)
        chosen = options or RunOptions()
        if record is not None or self.record is not None:
            chosen = dataclasses.replace(chosen, record=record if record is not None else self.record)
        if progress is not None:
            chosen = dataclasses.replace(chosen, progress=progress)
        result = backend.run(system.compiled, chosen)
        if self.aliases:
            result.signals = {self.aliases.get(k, k): v for k, v in result.signals.items()}
        return result


def load(
    path: str | Path,
    *,
    interface: Literal["cs", "me"] | None = None,
    step: float | None = None,
    models: Path | None = None,
) -> System:
    """Compile a system file or a single model, or read a compiled system; raises
    DiagnosticError on errors (CompiledFileError for an unusable compiled-system file).

    ``interface`` and ``step`` apply to a single ``.fmu`` only. A compiled-system file
    (``*.fmionnx.json``, written by ``fmionnx compile``) is read as it is, nothing compiled;
    ``models`` names the store its models are found in by hash (default: where they were).
    """
    target = Path(path)
    if target.name.lower().endswith(COMPILED_SUFFIX):
        from fmionnx.compile.systemfile import read_compiled

        return System(read_compiled(target, models=models))
    bag = DiagnosticBag()
    if target.suffix.lower() in MODEL_SUFFIXES:
        compiled = compile_single_model(target, bag, interface=interface, step=step)
    else:
        from fmionnx import api

        result = api.compile_system(target)
        bag.extend(result.diagnostics)
        compiled = result.system
    diagnostics = tuple(bag.sorted())
    if compiled is None or any(d.severity is Severity.ERROR for d in diagnostics):
        raise DiagnosticError([d for d in diagnostics if d.severity is Severity.ERROR])
    if target.suffix.lower() == ".fmu":
        component = compiled.components[0]
        refs = tuple(
            PortRef(component.name, p.name)
            for p in component.interface.with_causality(Causality.OUTPUT)
        )
        return System(compiled, diagnostics, fmu_aliases(component), refs)
    return System(compiled, diagnostics)


# -- single models ---------------------------------------------------------------------------


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


def fmu_aliases(component: Component) -> dict[str, str]:
    """Results column -> FMU variable name (FMI 2 arrays keep their scalar names ``x[1]``)."""
    names: dict[int, str] = {}
    try:
        from fmionnx.kinds.fmu.description import component_description
        from fmionnx.kinds.fmu.files import read_fmu_files

        md = component_description(
            component, lambda: read_fmu_files(component.path).model_description
        )
        names = {
            int(v.valueReference): str(v.name) for v in md.modelVariables if v.causality == "output"
        }
    except Exception:  # aliases are cosmetic; fall back to port names
        names = {}
    aliases = {}
    for port in component.interface.with_causality(Causality.OUTPUT):
        prefix = f"{component.name}.{port.name}"
        if port.is_scalar:
            aliases[prefix] = port.name
            continue
        size = port.size or 1
        per_element = len(port.vrs) == size
        for i in range(size):
            fallback = f"{port.name}[{i}]"
            name = names.get(port.vrs[i], fallback) if per_element else fallback
            aliases[f"{prefix}[{i}]"] = name
    return aliases


def run_onnx_once(
    system: System, inputs: Mapping[str, npt.ArrayLike]
) -> dict[str, npt.NDArray[np.generic]]:
    """Run a one-ONNX-model system once on ``inputs``; returns outputs shaped like the model's."""
    from fmionnx.core.runner import Wiring, get_output, set_input
    from fmionnx.kinds.registry import make_runner

    component = system.compiled.components[0]
    expected = {p.name: p for p in component.interface.with_causality(Causality.INPUT)}
    unknown = [n for n in inputs if n not in expected]
    if unknown:
        hint = did_you_mean(unknown[0], expected) or one_of(expected)
        msg = f"the model has no input `{unknown[0]}`; {hint}"
        raise OverrideError(msg)
    sizes = {n: int(np.asarray(v).size) for n, v in inputs.items()}
    runner = make_runner(component, Wiring(frozenset(inputs), sizes))
    runner.instantiate()
    try:
        runner.setup(0.0, 1.0)
        for name, value in inputs.items():
            array = np.asarray(value)
            buffer = runner.input_buffer(name)
            if array.size != buffer.size:
                port = expected[name]
                msg = (
                    f"input `{name}` needs {buffer.size} elements (shape {port.shape_text()}), "
                    f"got an array of shape {list(array.shape)}"
                )
                raise OverrideError(msg)
            set_input(runner, name, array)
        runner.step(0.0, 1.0)
        outputs = {}
        for port in component.interface.with_causality(Causality.OUTPUT):
            outputs[port.name] = get_output(runner, port.name)
        return outputs
    finally:
        runner.terminate()


# -- overrides -------------------------------------------------------------------------------


def override_stop(system: CompiledSystem, stop: float) -> CompiledSystem:
    """The system with another stop time (a whole number of base steps after the start)."""
    run = system.run
    if not math.isfinite(stop):
        msg = f"--stop-time {stop} must be a finite number of seconds"
        raise OverrideError(msg)
    if stop <= run.start:
        msg = f"--stop-time {stop} must be greater than the start time {run.start}"
        raise OverrideError(msg)
    if is_whole_multiple(stop - run.start, run.step, rel=1e-6) is None:
        msg = f"--stop-time {stop} is not a whole number of base steps ({run.step} s) after the start"
        raise OverrideError(msg)
    origins = (*((k, o) for k, o in run.origins if k != "stop"), ("stop", Origin.COMMAND_LINE))
    return dataclasses.replace(system, run=RunSettings(run.start, stop, run.step, origins))


def parse_value(text: str) -> Scalar | list[Scalar]:
    """A command-line value: JSON (``1.5``, ``true``, ``[1, 2]``), else the plain string."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return text
    if isinstance(value, list) and all(isinstance(v, bool | int | float | str) for v in value):
        return value
    if isinstance(value, bool | int | float | str):
        return value
    return text


def _coerce(dtype: DType, value: Scalar) -> Scalar | None:
    if dtype is DType.BOOL:
        return value if isinstance(value, bool) else None
    if dtype.is_integer:
        return value if isinstance(value, int) and not isinstance(value, bool) else None
    if dtype.is_float:
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        return float(value) if ok else None
    return value if isinstance(value, str) else None


def override_parameter(
    system: CompiledSystem, key: str, value: Scalar | list[Scalar]
) -> CompiledSystem:
    """The system with ``component.name = value`` set before initialization.

    A one-model system also accepts the bare variable name (``--param k=2``).
    """
    names = [c.name for c in system.components]
    owners = [n for n in names if key.startswith(n + ".")]
    if owners:
        component_name = max(owners, key=len)
        port_name = key[len(component_name) + 1 :]
    elif len(names) == 1:
        component_name, port_name = names[0], key  # a lone model: plain variable names
    elif "." not in key:
        msg = f"--param `{key}`: expected `component.name=value` (components: {', '.join(names)})"
        raise OverrideError(msg)
    else:
        guess = key.split(".", 1)[0]
        hint = did_you_mean(guess, names) or one_of(names)
        msg = f"--param `{key}`: no component `{guess}`; {hint}"
        raise OverrideError(msg)
    component = system.component(component_name)
    settable = [
        p.name
        for p in component.interface.ports
        if p.causality in (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER, Causality.INPUT)
    ]
    port = component.interface.port(port_name)
    if port is None or port.name not in settable:
        hint = did_you_mean(port_name, settable) or one_of(settable)
        msg = f"--param `{key}`: `{component_name}` has no parameter `{port_name}`; {hint}"
        raise OverrideError(msg)
    flat = value if isinstance(value, list) else [value]
    size = port.size or 1
    coerced = [_coerce(port.dtype, v) for v in flat]
    if len(flat) != size or any(c is None for c in coerced):
        msg = (
            f"--param `{key}`: expected {size} value(s) of type {port.dtype} "
            f"(shape {port.shape_text()}), got `{value}`"
        )
        raise OverrideError(msg)
    values = tuple(c for c in coerced if c is not None)
    kept = tuple(p for p in component.parameters if p.port != port_name)
    updated = dataclasses.replace(
        component, parameters=(*kept, ParameterValue(port_name, values, None))
    )
    components = tuple(updated if c.name == component_name else c for c in system.components)
    return dataclasses.replace(system, components=components)
