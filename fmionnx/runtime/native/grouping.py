"""Which components of a schedule the native kernel steps, and whether it is available.

A *group* is a maximal run of components that are consecutive in the compiled order, share
one period and are each eligible: an FMI 2 co-simulation FMU whose per-step values are all
real (one ``fmi2SetReal`` and one ``fmi2GetReal`` call, or none), whose incoming connections
copy float64 elements from non-lazy outputs. Inputs may come from anywhere: a component
outside the group runs either before the group (its newest value is read) or after it (its
held value is read), and nothing outside the group changes while the group steps, so the C
loop reads exactly the values the Python loop would. Everything else keeps the Python path.

``FMIONNX_NATIVE`` chooses the kernel: unset or ``1`` the library installed with fmionnx,
``build`` one compiled at run time (opt-in), ``0`` none. When the chosen library is missing or
refused (:mod:`.kernel`) the run goes on in Python; :class:`NativeStatus` says which library
ran, or why none did (debug log line, ``run.json``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.runner import Runner
from fmionnx.kinds.fmu.fmi2 import Fmi2CoSimulation
from fmionnx.runtime.native.group import MemberPlan, NativeGroup
from fmionnx.runtime.native.kernel import load_kernel
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.transfer import connection_views

LOG = logging.getLogger(__name__)

#: Environment switch: ``0`` keeps every component in the Python path, ``build`` compiles
#: the kernel at run time instead of loading the installed one, unset or ``1`` loads that.
SWITCH_ENV = "FMIONNX_NATIVE"
#: Its values; any other keeps the Python path, with that as the reason.
SETTINGS = ("", "1", "0", "build")

Tracks = Mapping[str, tuple[Track | None, Track | None]]


@dataclass(frozen=True)
class NativeStatus:
    """Whether the run used the native kernel, and if not, why (recorded in run.json)."""

    used: bool
    reason: str | None = None
    groups: int = 0
    components: int = 0
    #: ``installed`` or ``build`` (:attr:`.kernel.Kernel.origin`) when used.
    library: str | None = None
    sha256: str | None = None

    def details(self) -> dict[str, str | int | bool | None]:
        """The run.json fields."""
        return {
            "native": self.used,
            "native_reason": self.reason,
            "native_groups": self.groups,
            "native_components": self.components,
            "native_library": self.library,
            "native_sha256": self.sha256,
        }


@dataclass(frozen=True)
class NativePlan:
    """The execution order with native groups in place of their members."""

    status: NativeStatus
    schedule: tuple[str | NativeGroup, ...]


def member_plan(
    system: CompiledSystem, runners: Mapping[str, Runner], name: str, tracks: Tracks
) -> MemberPlan | None:
    """``name``'s part in a group, or None when it must stay in the Python path."""
    runner = runners[name]
    if not isinstance(runner, Fmi2CoSimulation):
        return None
    if system.loops and system.loop_of(name) is not None:
        return None  # an iterated loop steps its members itself, repeatedly
    calls = runner.fmi2_cs_calls()
    if calls is None:
        return None
    if any(c[2] != "fmi2SetReal" for c in calls.set_calls) or len(calls.set_calls) > 1:
        return None
    if any(c[2] != "fmi2GetReal" for c in calls.get_calls) or len(calls.get_calls) > 1:
        return None
    connections = system.inputs_of(name)
    views = []
    for connection in connections:
        source = runners[connection.src.component]
        if connection.src.port in source.lazy_outputs:
            return None
        src, dst = connection_views(connection, source, runner)
        if src.dtype != np.float64 or dst.dtype != np.float64:
            return None
        if not (src.flags.c_contiguous and dst.flags.c_contiguous):
            return None
        views.append((src, dst))
    return MemberPlan(
        name, runner, calls, connections, tuple(views), tracks.get(name, (None, None))
    )


def _runs(
    system: CompiledSystem, runners: Mapping[str, Runner], tracks: Tracks
) -> list[str | list[MemberPlan]]:
    """The order with maximal runs of eligible same-period components collected."""
    schedule: list[str | list[MemberPlan]] = []
    current: list[MemberPlan] = []
    period = 0
    for name in system.order:
        plan = member_plan(system, runners, name, tracks)
        steps = system.component(name).period_steps
        if plan is not None and current and steps == period:
            current.append(plan)
            continue
        if current:
            schedule.append(current)
            current = []
        if plan is None:
            schedule.append(name)
        else:
            current, period = [plan], steps
    if current:
        schedule.append(current)
    return schedule


def _python_only(system: CompiledSystem, reason: str) -> NativePlan:
    LOG.debug("native FMI 2 kernel not used: %s", reason)
    return NativePlan(NativeStatus(used=False, reason=reason), tuple(system.order))


def plan_native(
    system: CompiledSystem, runners: Mapping[str, Runner], tracks: Tracks
) -> NativePlan:
    """Group the prepared runners (after ``setup``) for native stepping where possible."""
    setting = os.environ.get(SWITCH_ENV, "").strip()
    if setting == "0":
        return _python_only(system, f"disabled by {SWITCH_ENV}=0")
    if setting not in SETTINGS:
        return _python_only(system, f"{SWITCH_ENV}={setting!r} is none of 0, 1, build")
    runs = _runs(system, runners, tracks)
    if all(isinstance(item, str) for item in runs):
        return _python_only(system, "no FMI 2 co-simulation FMU with only real per-step values")
    kernel = load_kernel(build=setting == "build")
    if isinstance(kernel, str):
        return _python_only(system, kernel)
    schedule: list[str | NativeGroup] = []
    for item in runs:
        if isinstance(item, str):
            schedule.append(item)
        else:
            steps = system.component(item[0].name).period_steps
            schedule.append(NativeGroup(kernel, item, steps))
    groups: Sequence[NativeGroup] = [g for g in schedule if isinstance(g, NativeGroup)]
    members = sum(len(g.names) for g in groups)
    LOG.debug(
        "native FMI 2 kernel (%s library %s, sha256 %s) steps %d components in %d groups",
        kernel.origin,
        kernel.path,
        kernel.sha256,
        members,
        len(groups),
    )
    status = NativeStatus(
        used=True,
        groups=len(groups),
        components=members,
        library=kernel.origin,
        sha256=kernel.sha256,
    )
    return NativePlan(status, tuple(schedule))
