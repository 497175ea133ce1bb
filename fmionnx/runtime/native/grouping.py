"""Which components of a schedule the native kernel steps, and whether it is available.

A *group* is a maximal run of components that are consecutive in the compiled order, share
one period and are each eligible: an FMI 2 or FMI 3 co-simulation FMU (in this process, not
in an iterated algebraic loop, an FMI 3 one without clocks) whose per-step values are
numbers (the runner's one get/set call per FMI type: Real/Integer/Boolean, or
Float64/Float32/Int8...UInt64/Boolean, arrays included), and whose incoming connections read
non-lazy outputs of a numeric element type, without turning a float into an integer. Inputs
may come from anywhere: a component outside the group runs either before the group (its
newest value is read) or after it (its held value is read), and nothing outside the group
changes while the group steps, so the C loop reads exactly the values the Python loop would.
Everything else keeps the Python path; :func:`member_plan` says why, per component
(``run.json`` ``execution.native_python.<component>``).

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

from fmionnx.compile.ir import CompiledSystem, Connection
from fmionnx.core.cosim import NativeCandidate, NativeSteppable
from fmionnx.core.runner import Buffer, Runner
from fmionnx.kinds.base import FMI
from fmionnx.kinds.registry import has_capability
from fmionnx.runtime.native.group import MemberPlan, NativeGroup, call_type, type_code
from fmionnx.runtime.native.kernel import SETTINGS, SWITCH_ENV, load_kernel
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.transfer import connection_views

LOG = logging.getLogger(__name__)


Tracks = Mapping[str, tuple[Track | None, Track | None]]

#: run.json ``execution`` key prefix: ``native_python.<component>`` is why it keeps Python.
PYTHON_PREFIX = "native_python."


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
    #: (component, why it keeps the Python path) for each component the kernel does not step,
    #: in the compiled order (empty when the kernel is off: ``reason`` says why).
    python: tuple[tuple[str, str], ...] = ()

    def details(self) -> dict[str, str | int | bool | None]:
        """The run.json fields: ``native_python.<component>`` for each entry of ``python``."""
        fields: dict[str, str | int | bool | None] = {
            "native": self.used,
            "native_reason": self.reason,
            "native_groups": self.groups,
            "native_components": self.components,
            "native_library": self.library,
            "native_sha256": self.sha256,
        }
        for name, why in self.python:
            fields[f"{PYTHON_PREFIX}{name}"] = why
        return fields


@dataclass(frozen=True)
class NativePlan:
    """The execution order with native groups in place of their members."""

    status: NativeStatus
    schedule: tuple[str | NativeGroup, ...]


#: Why a float is never converted into an integer natively.
_PLATFORM_CAST = "numpy's result for a float outside the integer's range depends on the platform"

#: Why a component's step stays in Python, by its kind (FMUs are judged one by one).
_OTHER_KINDS = "only FMI co-simulation FMUs run natively"


def _stepped_natively(runner: Runner) -> bool:
    """Whether an isolated runner says its child steps the model with the kernel
    (``IsolatedRunner.stepped_natively``; no other runner has the attribute)."""
    return getattr(runner, "stepped_natively", False) is True


def _runner_reason(system: CompiledSystem, name: str, runner: Runner) -> str | None:
    """Why ``name``'s runner cannot be a member, judged before its connections."""
    component = system.component(name)
    if not isinstance(runner, NativeCandidate):
        if has_capability(component, FMI):  # its runner is a proxy of a child process
            there = ", stepped there by the native kernel" if _stepped_natively(runner) else ""
            return f"runs in a child process (--isolate){there}"
        article = "an" if component.kind[:1] in "aeiou" else "a"
        return f"{article} {component.kind} component ({_OTHER_KINDS})"
    problem = runner.native_problem()
    if not isinstance(runner, NativeSteppable):
        return problem or "its runner makes no co-simulation calls"
    if system.loops and system.loop_of(name) is not None:
        return "a member of an iterated algebraic loop (the loop steps its members repeatedly)"
    return problem


def _connection_reason(connection: Connection, src: Buffer, dst: Buffer) -> str | None:
    """Why the kernel cannot copy ``connection`` exactly as :mod:`..transfer` does."""
    if type_code(src.dtype) is None or type_code(dst.dtype) is None:
        return f"the connection `{connection}` carries {src.dtype} to {dst.dtype} values"
    if dst.dtype.kind in "iu":
        if src.dtype.kind == "f":
            made = f"turns {src.dtype} into {dst.dtype}"
        elif not (connection.factor == 1.0 and connection.offset == 0.0):
            made = f"computes factor*x + offset in float64 and turns it into {dst.dtype}"
        else:
            made = ""
        if made:
            return f"the connection `{connection}` {made} ({_PLATFORM_CAST})"
    if not (src.flags.c_contiguous and dst.flags.c_contiguous):
        return f"the connection `{connection}` reads or writes non-contiguous elements"
    return None


def member_plan(
    system: CompiledSystem, runners: Mapping[str, Runner], name: str, tracks: Tracks
) -> MemberPlan | str:
    """``name``'s part in a group, or why it must stay in the Python path."""
    runner = runners[name]
    problem = _runner_reason(system, name, runner)
    if problem is not None:
        return problem
    assert isinstance(runner, NativeSteppable)
    calls = runner.cs_calls()
    if calls is None:
        return "not set up"
    for call in (*calls.set_calls, *calls.get_calls):
        if call_type(call) is None:
            return f"its {call[2]} values have no native element type"
    connections = system.inputs_of(name)
    views = []
    for connection in connections:
        source = runners[connection.src.component]
        if connection.src.port in source.lazy_outputs:
            return (
                f"its input `{connection.dst.port}` comes from `{connection.src}`, "
                "which is produced on demand"
            )
        src, dst = connection_views(connection, source, runner)
        problem = _connection_reason(connection, src, dst)
        if problem is not None:
            return problem
        views.append((src, dst))
    return MemberPlan(
        name, runner, calls, connections, tuple(views), tracks.get(name, (None, None))
    )


def _runs(
    system: CompiledSystem, runners: Mapping[str, Runner], tracks: Tracks
) -> tuple[list[str | list[MemberPlan]], dict[str, str]]:
    """The order with maximal runs of eligible same-period components collected, and why
    each other component keeps the Python path."""
    schedule: list[str | list[MemberPlan]] = []
    reasons: dict[str, str] = {}
    current: list[MemberPlan] = []
    period = 0
    for name in system.order:
        plan = member_plan(system, runners, name, tracks)
        steps = system.component(name).period_steps
        if not isinstance(plan, str) and current and steps == period:
            current.append(plan)
            continue
        if current:
            schedule.append(current)
            current = []
        if isinstance(plan, str):
            reasons[name] = plan
            schedule.append(name)
        else:
            current, period = [plan], steps
    if current:
        schedule.append(current)
    return schedule, reasons


def _python_only(
    system: CompiledSystem, reason: str, python: Mapping[str, str] | None = None
) -> NativePlan:
    LOG.debug("native kernel not used: %s", reason)
    status = NativeStatus(used=False, reason=reason, python=tuple((python or {}).items()))
    return NativePlan(status, tuple(system.order))


def plan_native(
    system: CompiledSystem,
    runners: Mapping[str, Runner],
    tracks: Tracks,
    *,
    nonfinite: str = "fault",
) -> NativePlan:
    """Group the prepared runners (after ``setup``) for native stepping where possible.

    The kernel stops at a non-finite value, as the Python path's default does; with
    ``nonfinite="warn"`` (values passed on) every component keeps the Python path.
    """
    setting = os.environ.get(SWITCH_ENV, "").strip()
    if setting == "0":
        return _python_only(system, f"disabled by {SWITCH_ENV}=0")
    if nonfinite != "fault":
        return _python_only(system, "--on-nonfinite warn passes non-finite values on")
    if setting not in SETTINGS:
        return _python_only(system, f"{SWITCH_ENV}={setting!r} is none of 0, 1, build")
    runs, reasons = _runs(system, runners, tracks)
    for name, why in reasons.items():
        LOG.debug("native kernel: component %s keeps the Python path: %s", name, why)
    if all(isinstance(item, str) for item in runs):
        return _python_only(system, "no component can run natively", reasons)
    kernel = load_kernel(build=setting == "build")
    if isinstance(kernel, str):
        return _python_only(system, kernel, reasons)
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
        "native kernel (%s library %s, sha256 %s) steps %d components in %d groups",
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
        python=tuple(reasons.items()),
    )
    return NativePlan(status, tuple(schedule))
