"""The study compiler: a study file and its system become a :class:`StudyPlan` (or diagnostics).

The system is compiled once. Every target is looked up in the compiled system (``run.stop``,
``run.output_interval``, a system input, ``component.parameter``, or a setting the
component's kind exposes, :class:`fmionnx.kinds.base.Settable`: an unknown name gets a
"did you mean"), every value of every axis is applied to it with the command line's own
overrides (so a value that ``fmionnx run --param`` would refuse is refused here, at its place
in the study file), the cases are enumerated in a fixed order, and the metrics are resolved
like the left side of a check. Nothing runs.

Cases: the grid axes combine as a cartesian product (the first target varies slowest); the
sampled targets draw ``sampling.samples`` rows from one seeded generator (``random`` targets
first, then one Latin-hypercube design over every ``latin_hypercube`` target); every grid
point is combined with every sample row. Same study file, same cases, same ids.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Literal

from fmionnx.compile.checks import compile_measure
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.overrides import OverrideError
from fmionnx.compile.studyir import (
    CHECK_PREFIX,
    METRIC_NAME_LENGTH,
    PLOTTED_METRICS,
    TABLE_COLUMNS,
    Case,
    Metric,
    Objective,
    Setting,
    SettingKind,
    SettingValue,
    StudyPlan,
    apply_setting,
)
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span, did_you_mean, one_of
from fmionnx.core.errors import ModelError
from fmionnx.core.steps import MAX_RUN_STEPS
from fmionnx.core.types import Causality
from fmionnx.kinds.base import Settable, SettingError
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.study import (
    AxisSpec,
    BoundsSpec,
    LoadedStudy,
    StudySpec,
    StudyValue,
    between,
    within,
)

#: More cases than this is a mistake in the study file (a grid axis too many), not a study.
MAX_CASES = 1_000_000
#: Run settings a study may vary (``run.<key>``), as the system file spells them.
RUN_TARGETS: dict[str, SettingKind] = {"run.stop": "stop", "run.output_interval": "output_interval"}
#: ``isolate`` words besides component names (as ``fmionnx run --isolate``).
ISOLATE_WORDS = ("fmus", "all", "none")


#: Compiles a study's system file: the compiled system (None on errors), diagnostics into the
#: bag. The pipeline hands in its compile cache's (``pipeline/system.py``).
SystemCompiler = Callable[[Path, DiagnosticBag], CompiledSystem | None]


def compile_study(
    loaded: LoadedStudy, bag: DiagnosticBag, *, system_compiler: SystemCompiler | None = None
) -> StudyPlan | None:
    """Compile the study's system (with ``system_compiler``, else from scratch) and resolve
    the study; None when anything is wrong."""
    spec = loaded.spec
    if spec is None:
        return None
    sources = loaded.sources
    system_path = loaded.path.parent / spec.system
    try:
        if system_path.is_file():
            problem = None
        elif system_path.is_dir():
            problem = "is a folder, not a system file"
        else:
            problem = "does not exist"
    except OSError as exc:  # a name too long, a loop of links: the file cannot be looked at
        problem = f"cannot be read: {exc.strerror}"
    if problem is not None:
        bag.emit(
            codes.STUDY_SYSTEM,
            f"the study's system file `{spec.system}` {problem}",
            sources.value(("system",)),
            hint="`system:` is relative to the study file",
        )
        return None
    system_bag = DiagnosticBag()
    system = (system_compiler or _compile_system)(system_path, system_bag)
    bag.extend(system_bag.sorted())
    if system is None or system_bag.has_errors:
        bag.emit(
            codes.STUDY_SYSTEM,
            f"the study's system `{spec.system}` does not compile (errors above)",
            sources.value(("system",)),
        )
        return None
    return resolve_study(spec, system, loaded, bag)


def _compile_system(path: Path, bag: DiagnosticBag) -> CompiledSystem | None:
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.spec.frontends import load_system

    loaded = load_system(path, bag)
    return compile_spec(loaded, bag) if loaded.spec is not None else None


def resolve_study(
    spec: StudySpec, system: CompiledSystem, loaded: LoadedStudy, bag: DiagnosticBag
) -> StudyPlan | None:
    """The plan of ``spec`` over the compiled ``system`` (problems into ``bag``)."""
    sources = loaded.sources
    kinds: dict[str, SettingKind] = {}
    for target in spec.parameters:
        kind = _target_kind(system, target, sources.key(("parameters", target)), bag)
        if kind is not None:
            kinds[target] = kind
    metrics = _metrics(spec, system, loaded, bag)
    objective = _objective(spec, loaded, bag)
    isolate = _isolation(spec, system, loaded, bag)
    columns_ok = _columns(spec, loaded, bag)
    if len(kinds) != len(spec.parameters) or not columns_ok:
        return None
    steps = system.run.steps
    if "stop" not in kinds.values() and steps > MAX_RUN_STEPS:  # each stop is checked below
        bag.emit(
            codes.STUDY_VALUES,
            f"the system's run is {steps:.3g} base steps of {system.run.step} s, more than the "
            f"{MAX_RUN_STEPS:.0e} a case may run",
            sources.value(("system",)),
            hint="vary `run.stop` in the study, or shorten the system's run",
        )
        return None
    axes = spec.parameters
    grid = {t: a.grid_values() for t, a in axes.items() if a.sampled is None}
    sampled = {t: a for t, a in axes.items() if a.sampled is not None}
    if sampled and spec.sampling is None:
        first = next(iter(sampled))
        bag.emit(
            codes.STUDY_VALUES,
            f"`{first}` is sampled, but the study has no `sampling: {{samples: N, seed: S}}`",
            sources.value(("parameters", first)),
            hint="add `sampling: {samples: 20, seed: 1}`: the number of rows and the seed",
        )
        return None
    if spec.sampling is not None and not sampled:  # a bug hunt: ignored, fewer cases than meant
        bag.emit(
            codes.STUDY_VALUES,
            "`sampling` draws the rows of sampled targets, and no target is sampled",
            sources.key(("sampling",)),
            hint="sample a target (`gain.k: {random: {low: 0, high: 1}}`), or remove `sampling`",
        )
        return None
    samples = spec.sampling.samples if sampled and spec.sampling is not None else 1
    count = math.prod(len(v) for v in grid.values()) * samples
    if count > MAX_CASES:
        bag.emit(
            codes.STUDY_SIZE,
            f"the study has {count} cases, more than {MAX_CASES}",
            sources.key(("parameters",)),
            hint="use fewer values per grid axis, or sample (`random`, `latin_hypercube`)",
        )
        return None
    rows = _sample_rows(
        sampled,
        spec.sampling.samples if spec.sampling else 0,
        spec.sampling.seed if spec.sampling else 0,
    )
    ok = True
    tried: dict[str, list[SettingValue | StudyValue]] = {t: list(v) for t, v in grid.items()}
    tried.update({t: [r[t] for r in rows] for t in sampled})
    for target, values in tried.items():
        hint = _range_hint(system, target, axes[target])
        ok = _check_values(system, target, kinds[target], values, loaded, bag, hint) and ok
    if not ok or metrics is None or bag.has_errors or isolate is None:
        return None
    cases = _cases(grid, rows or [{}], kinds, list(spec.parameters))
    return StudyPlan(
        name=loaded.path.name,
        system=system,
        targets=tuple(spec.parameters),
        cases=cases,
        metrics=metrics,
        objective=objective,
        isolate=isolate,
        timeout=spec.timeout,
        step_timeout=spec.step_timeout,
    )


def _target_kind(
    system: CompiledSystem, target: str, span: Span, bag: DiagnosticBag
) -> SettingKind | None:
    """What ``target`` names in ``system``; a diagnostic (with a suggestion) when nothing."""
    names = [c.name for c in system.components]
    if target in RUN_TARGETS and "run" not in names:
        return RUN_TARGETS[target]
    if any(i.name == target for i in system.inputs):
        return "parameter"
    owners = [n for n in names if target.startswith(n + ".")]
    if not owners:
        head = target.split(".", 1)[0]
        candidates = [*names, *(i.name for i in system.inputs)]
        if head == "run":
            bag.emit(
                codes.STUDY_TARGET,
                f"`{target}` is not a run setting a study can vary",
                span,
                hint=did_you_mean(target, RUN_TARGETS) or one_of(RUN_TARGETS),
            )
            return None
        hint = did_you_mean(head, candidates) or did_you_mean(target, candidates)
        bag.emit(
            codes.STUDY_TARGET,
            f"`{target}`: the system has no component `{head}`",
            span,
            hint=hint or (one_of(candidates) + " (a target is `component.parameter`)"),
        )
        return None
    component = system.component(max(owners, key=len))
    port_name = target[len(component.name) + 1 :]
    settable = [
        p.name
        for p in component.interface.ports
        if p.causality in (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER, Causality.INPUT)
    ]
    if port_name in settable:
        return "parameter"
    kind = COMPONENT_KINDS[component.kind]
    if not isinstance(kind, Settable):
        bag.emit(
            codes.STUDY_TARGET,
            f"`{target}`: `{component.name}` has no parameter `{port_name}`",
            span,
            hint=did_you_mean(port_name, settable) or one_of(settable),
        )
        return None
    try:
        settings = kind.settings(component)
    except ModelError as exc:
        bag.emit(
            codes.STUDY_SETTING,
            f"`{target}`: cannot read the settings of `{component.name}`: {exc}",
            span,
        )
        return None
    if port_name in settings:
        return "setting"
    names = [*settable, *settings]
    hint = kind.setting_hint(component, port_name)
    bag.emit(
        codes.STUDY_SETTING,
        f"`{target}`: `{component.name}` has no parameter or setting `{port_name}`",
        span,
        hint=hint or did_you_mean(port_name, names) or one_of(names),
    )
    return None


def _check_values(
    system: CompiledSystem,
    target: str,
    kind: SettingKind,
    values: Sequence[SettingValue | StudyValue],
    loaded: LoadedStudy,
    bag: DiagnosticBag,
    hint: str | None = None,
) -> bool:
    """Apply every value alone to the base system: a value that does not fit is E103
    (``hint``: what the axis could have written instead)."""
    # Each distinct value once; `true` and `1` are equal in Python (and in a dict's keys), not
    # to a model: both are tried (found by fuzzing: `[0.5, 1, true]` passed, its case failed).
    distinct = {_typed(frozen): frozen for frozen in map(_frozen, values)}
    for value in distinct.values():
        try:
            applied = apply_setting(system, Setting(target, kind, value))
        except SettingError as exc:
            bag.emit(
                codes.STUDY_SETTING_VALUE,
                f"`{target}`: {exc}",
                loaded.sources.value(("parameters", target)),
            )
            return False
        except OverrideError as exc:
            detail = str(exc).split(": ", 1)[-1] if str(exc).startswith("--param") else str(exc)
            detail = detail.replace("--stop-time", "run.stop").replace(
                "--output-interval", "run.output_interval"
            )
            bag.emit(
                codes.STUDY_VALUES,
                f"`{target}`: {detail}",
                loaded.sources.value(("parameters", target)),
                hint=hint,
            )
            return False
        steps = applied.run.steps
        if kind == "stop" and steps > MAX_RUN_STEPS:
            # A case runs as `fmionnx run` does, whose limit `sweep` has no option to raise:
            # said here, not as the same failure of every case.
            bag.emit(
                codes.STUDY_VALUES,
                f"`{target}`: run.stop {applied.run.stop:g} makes the run {steps:.3g} base steps of "
                f"{applied.run.step} s, more than the {MAX_RUN_STEPS:.0e} a case may run",
                loaded.sources.value(("parameters", target)),
                hint="a shorter `run.stop`, or a larger `run.step` in the system file",
            )
            return False
    return True


def _range_hint(system: CompiledSystem, target: str, axis: AxisSpec) -> str | None:
    """For a ``range`` of floats applied to an integer parameter: how it gives integers."""
    numbers = axis.range.numbers() if axis.range is not None else []
    if not numbers or not isinstance(numbers[0], float):
        return None
    owners = [c for c in system.components if target.startswith(c.name + ".")]
    if not owners:
        return None
    component = max(owners, key=lambda c: len(c.name))
    port = component.interface.port(target[len(component.name) + 1 :])
    if port is None or not port.dtype.is_integer:
        return None
    return (
        "a `range` gives integers when `start` and `stop` are written as integers and every "
        "number between them is whole (`num - 1` divides `stop - start`)"
    )


def _frozen(value: SettingValue | StudyValue) -> SettingValue:
    return tuple(value) if isinstance(value, list | tuple) else value


def _typed(value: object) -> object:
    """``value`` with the type of every scalar in it: a key under which `true` is not `1`."""
    if isinstance(value, list | tuple):
        return tuple(_typed(v) for v in value)
    return (type(value).__name__, value)


def _sample_rows(
    sampled: dict[str, AxisSpec], samples: int, seed: int
) -> list[dict[str, SettingValue]]:
    """``samples`` rows of the sampled targets from one seeded generator (empty: none)."""
    if not sampled:
        return []
    import numpy as np

    rng = np.random.default_rng(seed)
    random = [t for t, a in sampled.items() if a.random is not None]
    lhs = [t for t, a in sampled.items() if a.latin_hypercube is not None]
    columns: dict[str, list[float]] = {}
    if random:
        draws = rng.random((samples, len(random)))
        for j, target in enumerate(random):
            bounds = sampled[target].random
            assert bounds is not None
            columns[target] = [_drawn(bounds, float(u)) for u in draws[:, j]]
    if lhs:
        for target in lhs:  # one stratum per sample in every dimension, strata paired at random
            bounds = sampled[target].latin_hypercube
            assert bounds is not None
            strata = rng.permutation(samples)
            jitter = rng.random(samples)
            units = (strata + jitter) / samples
            columns[target] = [_drawn(bounds, float(u)) for u in units]
    order = list(sampled)
    return [{t: columns[t][i] for t in order} for i in range(samples)]


def _drawn(bounds: BoundsSpec, fraction: float) -> float:
    """The number ``fraction`` (in ``[0, 1)``) of the way through ``bounds``, rounded, and in
    ``[low, high)`` however close to the float limit the bounds are (``low + (high - low) * u``
    was infinite for every case from ``-1e308`` to ``1e308``)."""
    value = within(between(bounds.low, bounds.high, fraction), bounds.low, bounds.high)
    return value if value < bounds.high else math.nextafter(bounds.high, bounds.low)


def _cases(
    grid: dict[str, list[StudyValue]],
    rows: list[dict[str, SettingValue]],
    kinds: dict[str, SettingKind],
    order: list[str],
) -> tuple[Case, ...]:
    """Every grid point with every sample row, in a fixed order, with stable ids."""
    points = list(itertools.product(*grid.values()))
    total = len(points) * len(rows)
    width = max(4, len(str(total - 1)))
    cases: list[Case] = []
    for point, row in itertools.product(points, rows):
        values: dict[str, SettingValue] = {t: _frozen(v) for t, v in zip(grid, point, strict=True)}
        values.update(row)
        settings = tuple(Setting(t, kinds[t], values[t]) for t in order)
        cases.append(Case(f"case-{len(cases):0{width}d}", settings))
    return tuple(cases)


def _metrics(
    spec: StudySpec, system: CompiledSystem, loaded: LoadedStudy, bag: DiagnosticBag
) -> tuple[Metric, ...] | None:
    components = {c.name: c for c in system.components}
    metrics = []
    ok = True
    checks = {c.name for c in system.checks}
    for name, expression in spec.metrics.items():
        span = loaded.sources.value(("metrics", name))
        if name in checks:
            bag.emit(
                codes.STUDY_METRIC,
                f"metric `{name}` has the name of one of the system's checks",
                loaded.sources.key(("metrics", name)),
                hint="the table has a column per check and per metric: give the metric another name",
            )
            ok = False
            continue
        resolved = compile_measure(f"metric `{name}`", expression, components, span, bag)
        if resolved is None:
            ok = False
            continue
        text = " ".join(expression.split())
        metrics.append(Metric(name, text, resolved[0], resolved[1]))
    return tuple(metrics) if ok else None


def _columns(spec: StudySpec, loaded: LoadedStudy, bag: DiagnosticBag) -> bool:
    """Every target and metric can be a column of the study's table (E109), checked before
    the first case: the table is written after the last one, and a name it cannot take (two
    columns of one name, a metric called `status`) lost every case's row. A metric name also
    names a plot's file, so it is a short plain name. More metrics than the plots draw is a
    warning (W100)."""
    ok = True
    reserved = set(TABLE_COLUMNS)
    for target in spec.parameters:
        if target in reserved:
            bag.emit(
                codes.STUDY_COLUMN,
                f"the target `{target}` has the name of a column of the study's table",
                loaded.sources.key(("parameters", target)),
                hint="the table has the columns "
                + ", ".join(f"`{c}`" for c in TABLE_COLUMNS)
                + "; rename the system input",
            )
            ok = False
    for name in spec.metrics:
        where = loaded.sources.key(("metrics", name))
        problem = _metric_name_problem(name, spec)
        if problem is not None:
            bag.emit(
                codes.STUDY_COLUMN,
                f"metric `{_shortened(name)}`: {problem}",
                where,
                hint=_NAME_HINT,
            )
            ok = False
    if len(spec.metrics) > PLOTTED_METRICS:
        bag.emit(
            codes.STUDY_PLOTS,
            f"the study has {len(spec.metrics)} metrics: its summary plots draw {PLOTTED_METRICS} "
            "of them (the objective's first); the table has every one",
            loaded.sources.key(("metrics",)),
            hint="plot the others from `cases.parquet`",
        )
    return ok


_NAME_HINT = (
    f"a metric is named like `time_to_B`: a letter or `_`, then letters, digits, `_`, `.` or "
    f"`-`, at most {METRIC_NAME_LENGTH} characters"
)
_METRIC_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")


def _metric_name_problem(name: str, spec: StudySpec) -> str | None:
    if len(name) > METRIC_NAME_LENGTH:
        return f"the name has {len(name)} characters, more than {METRIC_NAME_LENGTH}"
    if name.startswith(CHECK_PREFIX.strip()):
        return "the name would be taken for a check's column (`check: NAME`)"
    if not _METRIC_NAME.fullmatch(name):
        return "the name is not a plain name (it names a column and a plot's file)"
    if name in TABLE_COLUMNS:
        return "the name is one of the study table's own columns"
    if name in spec.parameters:
        return "the name is also a target of the study (the table has a column for each)"
    return None


def _shortened(name: str) -> str:
    return name if len(name) <= 40 else f"{name[:24]}...{name[-8:]} ({len(name)} characters)"


def _objective(spec: StudySpec, loaded: LoadedStudy, bag: DiagnosticBag) -> Objective | None:
    if spec.objective is None:
        return None
    sense: Literal["minimize", "maximize"] = (
        "minimize" if spec.objective.minimize is not None else "maximize"
    )
    name = spec.objective.metric
    if name not in spec.metrics:
        bag.emit(
            codes.STUDY_OBJECTIVE,
            f"the objective names no metric `{name}`",
            loaded.sources.value(("objective", sense)),
            hint=did_you_mean(name, spec.metrics) or one_of(spec.metrics),
        )
        return None
    return Objective(name, sense)


def _isolation(
    spec: StudySpec, system: CompiledSystem, loaded: LoadedStudy, bag: DiagnosticBag
) -> tuple[str, ...] | None:
    """The ``isolate`` words, each a component name or ``fmus``/``all``/``none``; the worker
    selects the components with the runtime's own rule (``--isolate``)."""
    words = [*ISOLATE_WORDS, *(c.name for c in system.components)]
    for word in spec.isolate:
        if word not in words:
            bag.emit(
                codes.STUDY_TARGET,
                f"`isolate`: no component `{word}`",
                loaded.sources.value(("isolate",)),
                hint=did_you_mean(word, words) or one_of(words),
            )
            return None
    if "none" in spec.isolate and set(spec.isolate) != {"none"}:
        bag.emit(
            codes.STUDY_TARGET,
            "`isolate`: `none` stands alone: it cannot be given with `fmus`, `all` or a component",
            loaded.sources.value(("isolate",)),
        )
        return None
    return tuple(spec.isolate)
