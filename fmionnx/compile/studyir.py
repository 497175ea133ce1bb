"""A study as its workers need it: resolved cases, metrics and run options, nothing of the file.

The compiler of studies (:mod:`fmionnx.compile.study`) checks every target and value against
the compiled system once; a case is then only a list of :class:`Setting` values that
:func:`apply_case` turns into the case's own compiled system with the same overrides
``fmionnx run --param/--stop-time`` uses (:mod:`fmionnx.compile.overrides`), or, for a
setting a component's kind owns (a signal's amplitude, a scene's body position), with the
kind's own :meth:`~fmionnx.kinds.base.Settable.with_setting`. A worker that
received the base compiled system (as JSON) and a case derives the case's system itself: the
case is pure data, the derivation a pure function, so the same case gives the same system on
any host.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Literal

from fmionnx.compile.checkir import Expr
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.overrides import (
    OverrideError,
    apply_component_setting,
    override_output_interval,
    override_parameter,
    override_stop,
)
from fmionnx.core.types import PortRef, Scalar, ValueSource, is_number

#: The study table's own columns (besides one per target, metric and check): a target or a
#: metric of the same name would make two columns of one name, which the table refuses.
TABLE_COLUMNS = ("case", "status", "message", "wall_time", "worker")
#: Prefix of a check's column in the table (the check's name follows).
CHECK_PREFIX = "check: "
#: Most metrics drawn in the study's summary plots (one figure each); the table has them all.
PLOTTED_METRICS = 24
#: Longest metric name: it names a column and, in a plot's file name, a file.
METRIC_NAME_LENGTH = 64

#: What a setting changes: a parameter (or system input), the stop time, the output interval,
#: or a setting of a component's kind (``setting``: a signal's amplitude, a scene value).
SettingKind = Literal["parameter", "stop", "output_interval", "setting"]
#: A setting's value: a scalar, or a flat list for an array parameter.
SettingValue = Scalar | tuple[Scalar, ...]


@dataclass(frozen=True, slots=True)
class Setting:
    """One target's value in one case (``target`` as the study file writes it)."""

    target: str
    kind: SettingKind
    value: SettingValue


@dataclass(frozen=True, slots=True)
class Case:
    """One run of a study: its id (stable for a given study) and its settings."""

    id: str
    settings: tuple[Setting, ...]

    def values(self) -> dict[str, SettingValue]:
        """Target -> value, in the study's order."""
        return {s.target: s.value for s in self.settings}


@dataclass(frozen=True, slots=True)
class Metric:
    """A named measure (checks language), resolved like a check's left side."""

    name: str
    expression: str
    measure: Expr
    refs: tuple[PortRef, ...]


@dataclass(frozen=True, slots=True)
class Objective:
    """Rank cases by ``metric``, smallest first (``minimize``) or largest first."""

    metric: str
    sense: Literal["minimize", "maximize"]


@dataclass(frozen=True)
class StudyPlan:
    """A whole study, resolved: the base system, every case, the metrics and run options."""

    name: str
    system: CompiledSystem
    targets: tuple[str, ...]
    cases: tuple[Case, ...]
    metrics: tuple[Metric, ...] = ()
    objective: Objective | None = None
    #: ``isolate`` words (``fmus``, ``all``, ``none``, component names), as ``run --isolate``.
    isolate: tuple[str, ...] = ()
    timeout: float | None = None
    #: Seconds one step may take (None: ``timeout``).
    step_timeout: float | None = None

    @property
    def plotted_metrics(self) -> tuple[Metric, ...]:
        """The metrics the summary plots draw: the objective's first, at most
        :data:`PLOTTED_METRICS` (compiling warns, W100, when there are more)."""
        first = [m for m in self.metrics if self.objective and m.name == self.objective.metric]
        rest = [m for m in self.metrics if m not in first]
        return tuple([*first, *rest][:PLOTTED_METRICS])

    @property
    def check_names(self) -> tuple[str, ...]:
        """The system's checks, evaluated on every case."""
        return tuple(c.name for c in self.system.checks)

    @property
    def fingerprint(self) -> str:
        """sha256 over what decides the cases' results: ``--resume`` refuses a folder whose
        finished cases were run from another plan."""
        payload = {
            "system": self.system.content_hash,
            "cases": [
                [c.id, [[s.target, s.kind, _plain(s.value)] for s in c.settings]]
                for c in self.cases
            ],
            "metrics": [[m.name, m.expression] for m in self.metrics],
            # not in the system's content hash (they do not change what is simulated), but
            # they decide a case's row: its pass/fail columns and the rows metrics measure
            "checks": [[c.name, c.comparison, c.bound, c.expression] for c in self.system.checks],
            "output_interval": self.system.run.output_interval,
            "isolate": list(self.isolate),
            "timeout": self.timeout,
            "step_timeout": self.step_timeout,
        }
        text = json.dumps(payload, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def _plain(value: SettingValue) -> object:
    return list(value) if isinstance(value, tuple) else value


def apply_setting(system: CompiledSystem, setting: Setting) -> CompiledSystem:
    """``system`` with one setting applied (OverrideError when the value does not fit)."""
    if setting.kind == "stop":
        return override_stop(system, _seconds(setting.value, "--stop-time"))
    if setting.kind == "output_interval":
        return override_output_interval(system, _seconds(setting.value, "--output-interval"))
    if setting.kind == "setting":
        return apply_kind_setting(system, setting.target, setting.value)
    value = list(setting.value) if isinstance(setting.value, tuple) else setting.value
    return override_parameter(system, setting.target, value, ValueSource.STUDY)


def _seconds(value: SettingValue, flag: str) -> float:
    """A run setting's value, which the study file may give as anything YAML holds."""
    if not is_number(value):
        shown = json.dumps(_plain(value))
        msg = f"{flag} {shown} must be a finite number of seconds"
        raise OverrideError(msg)
    return float(value)


def owner(system: CompiledSystem, target: str) -> tuple[str, str] | None:
    """``(component, rest)`` of ``component.rest`` (the longest matching component name)."""
    owners = [c.name for c in system.components if target.startswith(c.name + ".")]
    if not owners:
        return None
    name = max(owners, key=len)
    return name, target[len(name) + 1 :]


def apply_kind_setting(system: CompiledSystem, target: str, value: SettingValue) -> CompiledSystem:
    """``system`` with the kind setting ``component.name`` at ``value`` (SettingError when the
    kind refuses it): see :func:`fmionnx.compile.overrides.apply_component_setting`."""
    from fmionnx.kinds.base import SettingError

    found = owner(system, target)
    if found is None:
        raise SettingError(f"`{target}` names no component")
    return apply_component_setting(system, system.component(found[0]), found[1], value)


def apply_case(system: CompiledSystem, case: Case) -> CompiledSystem:
    """The case's compiled system: the base with every setting applied, in order."""
    for setting in case.settings:
        system = apply_setting(system, setting)
    return system
