"""The ROS 2 plan a node or the supervisor runs: the compiled system's own, or one for another
distribution.

The compiled system carries the plan of its ``ros2:`` section's distribution. ``--ros-distro``
may ask for another one (message definitions and type hashes differ); the plan is then derived
from the same compiled system, never from the system file. Which distribution applies is
decided in one place, :func:`resolve_distro`: ``--ros-distro`` when given, else the system's
own, else the default (the current LTS).
"""

from __future__ import annotations

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import DEFAULT_DISTRO, RosDistro
from fmionnx.compile.ros2.plan import build_plan
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.core.diagnostics import Severity
from fmionnx.core.errors import DiagnosticError


def system_distro(system: CompiledSystem) -> RosDistro:
    """The distribution the compiled system names: its plan's (a compiled file written for a
    run carries the run's), else its ``ros2:`` section's, else :data:`DEFAULT_DISTRO`."""
    if system.ros2_plan is not None:
        return system.ros2_plan.distro
    if system.ros2 is not None:
        return system.ros2.distro
    return DEFAULT_DISTRO


def resolve_distro(system: CompiledSystem, requested: RosDistro | None) -> RosDistro:
    """``--ros-distro`` (``requested``) when given, else the system's own distribution."""
    return requested if requested is not None else system_distro(system)


def plan_for(system: CompiledSystem, distro: RosDistro | None = None) -> Ros2Plan:
    """The ROS 2 plan of ``system`` for ``distro`` (None: the system's own distribution);
    DiagnosticError when it does not map."""
    distro = resolve_distro(system, distro)
    if system.ros2_plan is not None and system.ros2_plan.distro is distro:
        return system.ros2_plan
    plan, diagnostics = build_plan(system, distro)
    errors = [d for d in diagnostics if d.severity is Severity.ERROR]
    if plan is None or errors:
        raise DiagnosticError(errors)
    return plan
