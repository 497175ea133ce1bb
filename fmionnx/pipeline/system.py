"""Loading: a system file, a compiled system or a single model becomes a :class:`System`.

``load`` accepts a system file (YAML/SSP), a compiled system (``*.fmionnx.json``) or a single
model: an ``.fmu`` becomes a one-component system run from its default experiment with every
output recorded under its variable name; an ``.onnx`` file gives a system whose one step
runs the model once. A :class:`System` is immutable: overrides make a new one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypeAlias, Unpack, cast

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.overrides import (
    OverrideError,
    override_output_interval,
    override_parameter,
    override_stop,
    plain_value,
)
from fmionnx.compile.runflags import RunFlags, apply_run_flags, mark_command_line
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Severity
from fmionnx.core.errors import DiagnosticError
from fmionnx.core.types import Causality, PortRef, Scalar, is_number
from fmionnx.pipeline.request import COMPILED_SUFFIX, RunSettings

if TYPE_CHECKING:  # numpy loads when a system runs, not with `import fmionnx`
    from collections.abc import Sequence

    import numpy as np
    import numpy.typing as npt

    from fmionnx.pipeline.compilecache import Slot
    from fmionnx.pipeline.observers import RunObserver
    from fmionnx.pipeline.run import SignalNames
    from fmionnx.runtime.result import ProgressCallback, RunOptions, RunResult

#: A parameter's value as a Python caller gives it (``params=``): a plain value or a list of
#: them, numpy's (``np.int64(2)``, ``np.float32(0.5)``, ``np.bool_(True)``, an array) or a
#: tuple, each taken as the plain value it holds (:func:`plain_value`). Typed ``Scalar``
#: only, the numpy values taken at run time failed a caller's type check (a bug hunt).
#: Quoted: numpy is imported for type checkers only.
ParamInput: TypeAlias = (
    "Scalar | np.generic | npt.NDArray[np.generic] | Sequence[Scalar | np.generic]"
)

#: Single-model files ``load`` accepts besides system files.
MODEL_SUFFIXES = (".fmu", ".onnx")


@dataclass(frozen=True)
class System:
    """A compiled system ready to run; immutable (overrides make a new one).

    ``aliases`` rename results columns (a single FMU's by variable name); ``record`` is the
    signals a single FMU records (every output); ``source`` the file it was loaded from.
    """

    compiled: CompiledSystem
    diagnostics: tuple[Diagnostic, ...] = ()
    aliases: Mapping[str, str] = field(default_factory=dict)
    record: tuple[PortRef, ...] | None = None
    source: Path | None = None

    @property
    def name(self) -> str:
        """The system's name."""
        return self.compiled.name

    def with_overrides(
        self,
        *,
        stop_time: float | None = None,
        params: Mapping[str, ParamInput] | None = None,
        output_interval: float | None = None,
    ) -> System:
        """A new System with a different stop time, output interval and/or parameter values
        (numpy values too: :data:`ParamInput`)."""
        compiled = self.compiled
        if stop_time is not None:
            compiled = override_stop(compiled, _seconds(stop_time, "--stop-time"))
        if output_interval is not None:
            compiled = override_output_interval(
                compiled, _seconds(output_interval, "--output-interval")
            )
        for key, value in (params or {}).items():
            # A value of none of Scalar's types is refused, naming it, by override_parameter.
            plain = cast("Scalar | list[Scalar]", plain_value(value))
            compiled = override_parameter(compiled, key, plain)
        return dataclasses.replace(self, compiled=compiled)

    def run(
        self,
        *,
        signals: SignalNames | None = None,
        progress: ProgressCallback | None = None,
        options: RunOptions | None = None,
        observers: tuple[RunObserver, ...] = (),
        **settings: Unpack[RunSettings],
    ) -> RunResult:
        """Run as ``fmionnx run`` would (the same options by name, the same defaults: FMUs
        isolated, no results folder unless ``out``) and return the recorded signals
        (``result["comp.port"]``); :func:`fmionnx.run` returns the checks and files too.

        ``signals`` narrows what is recorded (``("gain.y", "plant.x[0]")``, PortRefs too;
        ``()``: nothing; a name of no port: RequestError). ``options`` runs the
        in-process master with exactly these :class:`RunOptions` instead (a benchmark's or a
        test's choice: no isolation unless they say so, nothing written).
        """
        from fmionnx.pipeline.run import run_system, run_with_options

        if options is not None:
            return run_with_options(self, options, signals=signals, progress=progress, **settings)
        return run_system(
            self, signals=signals, progress=progress, observers=observers, **settings
        ).result


def _seconds(value: object, option: str) -> float:
    """A time from a Python caller as a float (a numpy number too: np.int64(1)); another
    value is an OverrideError naming the option, not a TypeError deep in the checks."""
    plain = plain_value(value)
    if not is_number(plain):
        msg = f"{option} takes a number of seconds, not `{value}`"
        raise OverrideError(msg)
    return float(plain)


def load(
    path: str | Path,
    *,
    interface: Literal["cs", "me"] | None = None,
    step: float | None = None,
    models: Path | None = None,
    start: float | None = None,
    stop: float | None = None,
) -> System:
    """Compile a system file or a single model, or read a compiled system; raises
    DiagnosticError on errors (CompiledFileError for an unusable compiled-system file).

    ``interface`` applies to a single ``.fmu`` only; ``step``, ``start`` and ``stop`` replace
    the run's base step, start and stop time of any system before it is compiled
    (:mod:`.compile.runflags`; a start past the file's stop needs ``stop``).
    A compiled-system file (``*.fmionnx.json``, written by ``fmionnx compile``) is read as it
    is, nothing compiled (``step``/``start`` are refused: OverrideError; ``stop`` is applied
    as ``System.with_overrides`` applies it); ``models`` names the store its models are found
    in by hash (default: where they were).
    """
    target = Path(path)
    flags = RunFlags(start=start, step=step, stop=stop)
    if target.name.lower().endswith(COMPILED_SUFFIX):
        from fmionnx.compile.systemfile import read_compiled

        if flags.start is not None or flags.step is not None:
            msg = "--step and --start-time need a system file: a compiled system is run as it is"
            raise OverrideError(msg)
        read = System(read_compiled(target, models=models), source=target)
        return read if stop is None else read.with_overrides(stop_time=stop)
    if target.suffix.lower() in MODEL_SUFFIXES:
        result = compile_model(target, flags, interface)
    else:
        result = compile_system(target, flags)
    compiled, diagnostics = result.system, result.diagnostics
    if compiled is None or any(d.severity is Severity.ERROR for d in diagnostics):
        raise DiagnosticError([d for d in diagnostics if d.severity is Severity.ERROR])
    if target.suffix.lower() == ".fmu":
        from fmionnx.kinds.registry import result_aliases

        component = compiled.components[0]
        refs = tuple(
            PortRef(component.name, p.name)
            for p in component.interface.with_causality(Causality.OUTPUT)
        )
        return System(compiled, diagnostics, result_aliases(component), refs, target)
    return System(compiled, diagnostics, source=target)


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
    start time and base step first (``fmionnx run --start-time/--step``).

    A YAML system compiled before, unchanged and with unchanged models, is read back from the
    compile cache (:mod:`.compilecache`) with the same diagnostics instead.
    """
    from fmionnx.pipeline import compilecache

    target = Path(path)
    place = compilecache.slot(target, flags)
    cached = compilecache.lookup(place)
    if cached is not None:
        return CompileResult(cached.system, cached.diagnostics)
    result = _compile_system(target, flags)
    if result.system is not None and result.ok:
        compilecache.store(place, result.system, result.diagnostics)
    return result


def compile_model(
    path: Path, flags: RunFlags, interface: Literal["cs", "me"] | None = None
) -> CompileResult:
    """Compile a lone model into a one-component system (:mod:`fmionnx.compile.single`), or
    read its compile back from the compile cache: the compile loads the kinds' pydantic specs
    and the run settings' types, which a lone FMU's run needs nothing else of."""
    from fmionnx.pipeline import compilecache

    place = compilecache.model_slot(path, flags, interface)
    cached = compilecache.lookup(place)
    if cached is not None:
        return CompileResult(cached.system, cached.diagnostics)
    from fmionnx.compile.single import compile_single_model

    bag = DiagnosticBag()
    compiled = compile_single_model(
        path, bag, interface=interface, step=flags.step, start=flags.start, stop=flags.stop
    )
    if compiled is not None:
        compiled = mark_command_line(compiled, flags)
    result = CompileResult(compiled, tuple(bag.sorted()))
    if compiled is not None and result.ok:
        compilecache.store(place, compiled, result.diagnostics)
    return result if result.ok else CompileResult(None, result.diagnostics)


def compiled_before(path: str | Path, flags: RunFlags | None = None) -> CompileResult | None:
    """The compile of a system file kept in the compile cache, unchanged since, or None; reads
    no system file types (a study file, never compiled this way, has no entry)."""
    from fmionnx.pipeline import compilecache

    cached = compilecache.lookup(compilecache.slot(Path(path), flags))
    return None if cached is None else CompileResult(cached.system, cached.diagnostics)


def check_if_study(path: str | Path) -> CompileResult | None:
    """:func:`check_study` of ``path`` when it is a study file, else None (``validate``).

    A check kept in the compile cache is read back before anything tells a study file from a
    system file (which imports the study file's types: a system file has no such entry),
    and the lookup is not repeated for a study that must be checked."""
    from fmionnx.pipeline.keptstudy import plan_slot

    place = plan_slot(Path(path))
    kept = _kept_check(place)
    if kept is not None or not is_study_file(path):
        return kept
    return _checked_study(Path(path), place)


def _compile_system(path: Path, flags: RunFlags | None) -> CompileResult:
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.spec.frontends import load_system

    bag = DiagnosticBag()
    loaded = load_system(path, bag)
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
    from fmionnx.spec.suffixes import SYSTEM_SUFFIXES

    target = Path(path)
    if target.suffix.lower() in SYSTEM_SUFFIXES or target.name.lower().endswith(COMPILED_SUFFIX):
        return False
    return kind_for_path(target) is not None


def check_model(path: str | Path) -> CompileResult:
    """Validate one model file alone (``fmionnx validate model.fmu``).

    The model is compiled as ``run`` would compile it (every check a system applies to it),
    then its kind's deeper checks run: FMPy's validation for an FMU, the ONNX checker and
    strict shape inference for an ONNX model, MuJoCo's compiler for a scene.

    A check that found no error is kept in the compile cache, as a compile is: an unchanged
    model is not parsed (its bytes are hashed), nor its libraries imported, the next time
    (the report is the same).
    """
    from fmionnx.pipeline import compilecache

    target = Path(path)
    place = compilecache.model_slot(target, RunFlags(), None, checked=True)
    cached = compilecache.lookup(place)
    if cached is not None:
        return CompileResult(cached.system, cached.diagnostics)
    from fmionnx.compile.single import check_single_model  # pydantic: for a lone model only

    bag = DiagnosticBag()
    system = check_single_model(target, bag)
    diagnostics = tuple(bag.sorted())
    if any(d.severity is Severity.ERROR for d in diagnostics):
        system = None
    elif system is not None:
        compilecache.store(place, system, diagnostics)
    return CompileResult(system, diagnostics)


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
    running a case: every diagnostic ``fmionnx sweep`` would stop on, at its place. A study
    that compiled without errors is kept in the compile cache, as ``sweep`` keeps it."""
    from fmionnx.pipeline.keptstudy import plan_slot

    place = plan_slot(Path(path))
    kept = _kept_check(place)
    return kept if kept is not None else _checked_study(Path(path), place)


def _kept_check(place: Slot | None) -> CompileResult | None:
    """The check of a study kept in ``place``, or None."""
    from fmionnx.pipeline.keptstudy import kept_plan

    kept = kept_plan(place)
    return None if kept is None else CompileResult(kept.plan.system, kept.diagnostics)


def _checked_study(path: Path, place: Slot | None) -> CompileResult:
    """A study file checked (compiled), its plan kept in ``place`` when it has no error."""
    from fmionnx.pipeline.keptstudy import compiled_plan
    from fmionnx.spec.study import load_study

    bag = DiagnosticBag()
    plan, diagnostics = compiled_plan(load_study(path, bag), bag, place)
    return CompileResult(None if plan is None else plan.system, diagnostics)


def study_system(path: Path, bag: DiagnosticBag) -> CompiledSystem | None:
    """A study's system compiled as :func:`compile_system` compiles it (the compile cache
    included); its diagnostics into ``bag``."""
    result = compile_system(path)
    bag.extend(result.diagnostics)
    return result.system
