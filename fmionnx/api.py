"""The Python API: everything the CLI does, callable from code and tests.

    >>> import fmionnx
    >>> system = fmionnx.load("systems/sign_follower.yaml")
    >>> result = system.run(stop_time=5.0)
    >>> result["odometry.posX"][-1], result.status

    >>> from fmionnx import api
    >>> checked = api.compile_system("systems/sign_follower.yaml")
    >>> checked.ok, [str(d.span) for d in checked.diagnostics]

A single FMU's results are named by variable (``result["x"]``), like ``fmpy simulate``.
``load`` accepts a system file (YAML/SSP), a compiled system (``*.fmionnx.json``) or a single
model: an ``.fmu`` becomes a one-component system run from its default experiment with every
output recorded under its variable name; an ``.onnx`` file gives a system whose ``infer``
runs the model once.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.overrides import (
    OverrideError,
    override_output_interval,
    override_parameter,
    override_stop,
    parse_value,
)
from fmionnx.compile.runflags import RunFlags, apply_run_flags, mark_command_line
from fmionnx.compile.single import check_single_model, compile_single_model
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Severity, did_you_mean, one_of
from fmionnx.core.errors import DiagnosticError
from fmionnx.core.types import (
    Causality,
    Component,
    PortRef,
    Scalar,
)

if TYPE_CHECKING:  # numpy and the runtime load when a system runs, not for `validate` / `--help`
    import numpy as np
    import numpy.typing as npt
    import pandas as pd

    from fmionnx.results.sweep import SweepProgress
    from fmionnx.runtime.result import ProgressCallback, RunOptions, RunResult

__all__ = [
    "CompileResult",
    "OverrideError",
    "System",
    "check_model",
    "compile_system",
    "is_model_file",
    "load",
    "parse_value",
    "run_onnx_once",
    "sweep",
]

#: Single-model files ``load`` accepts besides system files.
MODEL_SUFFIXES = (".fmu", ".onnx")
#: Compiled-system files (:mod:`fmionnx.compile.systemfile`; the same suffix, kept import-free).
COMPILED_SUFFIX = ".fmionnx.json"


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
        output_interval: float | None = None,
    ) -> System:
        """A new System with a different stop time, output interval and/or parameter values."""
        compiled = self.compiled
        if stop_time is not None:
            compiled = override_stop(compiled, stop_time)
        if output_interval is not None:
            compiled = override_output_interval(compiled, output_interval)
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
        from fmionnx.runtime.result import RunOptions

        chosen = options or RunOptions()
        if record is not None or self.record is not None:
            chosen = dataclasses.replace(
                chosen, record=record if record is not None else self.record
            )
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
    start: float | None = None,
) -> System:
    """Compile a system file or a single model, or read a compiled system; raises
    DiagnosticError on errors (CompiledFileError for an unusable compiled-system file).

    ``interface`` applies to a single ``.fmu`` only; ``step`` and ``start`` replace the run's
    base step and start time of any system before it is compiled (:mod:`.compile.runflags`).
    A compiled-system file (``*.fmionnx.json``, written by ``fmionnx compile``) is read as it
    is, nothing compiled (``step``/``start`` are refused: OverrideError); ``models`` names the
    store its models are found in by hash (default: where they were).
    """
    target = Path(path)
    flags = RunFlags(start=start, step=step)
    if target.name.lower().endswith(COMPILED_SUFFIX):
        from fmionnx.compile.systemfile import read_compiled

        if flags.keys:
            msg = "--step and --start-time need a system file: a compiled system is run as it is"
            raise OverrideError(msg)
        return System(read_compiled(target, models=models))
    bag = DiagnosticBag()
    if target.suffix.lower() in MODEL_SUFFIXES:
        compiled = compile_single_model(target, bag, interface=interface, step=step, start=start)
        if compiled is not None:
            compiled = mark_command_line(compiled, flags)
    else:
        result = compile_system(target, flags)
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
    import numpy as np

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


# -- checking ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CompileResult:
    """A compiled system (None when there were errors) and every diagnostic, sorted."""

    system: CompiledSystem | None
    diagnostics: tuple[Diagnostic, ...]

    @property
    def ok(self) -> bool:
        """True when no diagnostic is an error."""
        return all(d.severity is not Severity.ERROR for d in self.diagnostics)


def compile_system(path: str | Path, flags: RunFlags | None = None) -> CompileResult:
    """Load, check and compile a system file (YAML or SSP) into the IR; ``flags`` replace its
    start time and base step first (``fmionnx run --start-time/--step``)."""
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.spec.frontends import load_system

    bag = DiagnosticBag()
    loaded = load_system(Path(path), bag)
    if flags is not None:
        loaded = apply_run_flags(loaded, flags, bag)
    system = None
    if loaded.spec is not None:
        system = compile_spec(loaded, bag)
        if system is not None and flags is not None:
            system = mark_command_line(system, flags)
    diagnostics = tuple(bag.sorted())
    if any(d.severity is Severity.ERROR for d in diagnostics):
        system = None
    return CompileResult(system, diagnostics)


def is_model_file(path: str | Path) -> bool:
    """True for a file ``validate`` checks as a lone model: one a component kind reads
    (``.fmu`` or an unpacked FMU, ``.onnx``, a MuJoCo ``.xml``, a signal ``.csv``) that is not
    a system file."""
    from fmionnx.kinds.registry import kind_for_path
    from fmionnx.spec.frontends import FRONTENDS

    target = Path(path)
    if target.suffix.lower() in FRONTENDS or target.name.lower().endswith(COMPILED_SUFFIX):
        return False
    return kind_for_path(target) is not None


def check_model(path: str | Path) -> CompileResult:
    """Validate one model file alone (``fmionnx validate model.fmu``).

    The model is compiled as ``run`` would compile it (every check a system applies to it),
    then its kind's deeper checks run: FMPy's validation for an FMU, the ONNX checker and
    strict shape inference for an ONNX model, MuJoCo's compiler for a scene.
    """
    bag = DiagnosticBag()
    system = check_single_model(Path(path), bag)
    diagnostics = tuple(bag.sorted())
    if any(d.severity is Severity.ERROR for d in diagnostics):
        system = None
    return CompileResult(system, diagnostics)


# -- studies -----------------------------------------------------------------------------------


def is_study_file(path: str | Path) -> bool:
    """True for a YAML file that is a study (it names a ``system:`` to vary and has no
    ``components:``): ``validate`` checks it as ``fmionnx sweep`` would compile it."""
    from fmionnx.spec.yaml import is_study_text, read_text

    target = Path(path)
    if target.suffix.lower() not in {".yaml", ".yml"} or not target.is_file():
        return False
    text = read_text(target, DiagnosticBag())  # an unreadable file is the compiler's to report
    return text is not None and is_study_text(text, target)


def check_study(path: str | Path) -> CompileResult:
    """Check a study file and the system it varies (``fmionnx validate study.yaml``), without
    running a case: every diagnostic ``fmionnx sweep`` would stop on, at its place."""
    from fmionnx.compile.study import compile_study
    from fmionnx.spec.study import load_study

    bag = DiagnosticBag()
    plan = compile_study(load_study(Path(path), bag), bag)
    diagnostics = tuple(bag.sorted())
    ok = plan is not None and all(d.severity is not Severity.ERROR for d in diagnostics)
    return CompileResult(plan.system if ok and plan is not None else None, diagnostics)


def sweep(
    study: str | Path,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    keep_results: bool = False,
    force: bool = False,
    progress: SweepProgress | None = None,
    batch: int | None = None,
) -> pd.DataFrame:
    """Run a study file's cases (``fmionnx sweep``) and return its table, one row per case.

    ``scheduler`` is an existing Dask cluster (``tcp://host:8786``); without it a local
    cluster of ``workers`` processes (default: one per core) runs the cases. Results go to
    ``out`` (docs/sweep.md); ``resume`` finishes an interrupted study there, ``force``
    replaces an earlier study's results there. ``batch`` fixes the cases per Dask task (1: one
    each; default: short cases are batched by their measured time). Raises
    DiagnosticError for a study (or system) file with errors, before anything runs.
    A script calling it must do so under ``if __name__ == "__main__":``: the local cluster's
    workers import the script again (called from one of them, it raises ClusterStartError).
    """
    from fmionnx.backends.sweep.engine import refuse_in_starting_worker
    from fmionnx.results.sweep import plan_study, run_sweep

    refuse_in_starting_worker()
    plan, _ = plan_study(study)
    result = run_sweep(
        plan, Path(out), scheduler=scheduler, workers=workers, resume=resume,
        keep_results=keep_results, force=force, progress=progress, batch=batch,
    )  # fmt: skip
    return result.table
