"""The ROS 2 plan a node or the supervisor runs: the compiled system's own, or one for another
distribution.

The compiled system carries the plan of its ``ros2:`` section's distribution. ``--ros-distro``
may ask for another one (message definitions and type hashes differ); the plan is then derived
from the same compiled system, never from the system file.
"""

from __future__ import annotations

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.plan import build_plan
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.core.diagnostics import Severity
from fmionnx.core.errors import DiagnosticError


def plan_for(system: CompiledSystem, distro: RosDistro) -> Ros2Plan:
    """The ROS 2 plan of ``system`` for ``distro``; DiagnosticError when it does not map."""
    if system.ros2_plan is not None and system.ros2_plan.distro is distro:
        return system.ros2_plan
    plan, diagnostics = build_plan(system, distro)
    errors = [d for d in diagnostics if d.severity is Severity.ERROR]
    if plan is None or errors:
        raise DiagnosticError(errors)
    return plan
