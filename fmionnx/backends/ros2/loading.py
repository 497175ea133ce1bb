"""Compile a system for ROS 2: the same file, the same overrides, the same plan in every process.

A node compiles the system file itself (it may run on another host, from a launch file), so the
supervisor hands each node the file and its command-line overrides, not a pickled object, and
checks the compiled system's content hash in the ready hand-shake's log.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.plan import build_plan
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.core.diagnostics import Severity
from fmionnx.core.errors import DiagnosticError


def load_system(
    path: Path, *, stop_time: float | None = None, params: Mapping[str, str] | None = None
) -> CompiledSystem:
    """Compile ``path`` and apply ``--stop-time`` / ``--param`` (DiagnosticError, OverrideError)."""
    from fmionnx import session

    system = session.load(path)
    values = {k: session.parse_value(v) for k, v in (params or {}).items()}
    return system.with_overrides(stop_time=stop_time, params=values).compiled


def plan_for(system: CompiledSystem, distro: RosDistro) -> Ros2Plan:
    """The ROS 2 plan of ``system``; DiagnosticError when it does not map."""
    plan, diagnostics = build_plan(system, distro)
    errors = [d for d in diagnostics if d.severity is Severity.ERROR]
    if plan is None or errors:
        raise DiagnosticError(errors)
    return plan
