"""A ROS 2 Python launch file running every node of a system (``fmionnx ros2 launch-file``).

One ``ExecuteProcess`` per non-external component, each ``fmionnx node SYSTEM COMPONENT --sync
free``: without a supervisor the simulator node is the clock (it starts once the readers of its
topics matched) and every other node follows ``/clock``. The system file is referenced
relative to the launch file when it can be, so the pair can move together.
"""

from __future__ import annotations

import os
from pathlib import Path

from fmionnx.compile.ros2.types import Ros2Plan

_TEMPLATE = '''"""ROS 2 launch file for the fmionnx system `{name}` (written by `fmionnx ros2 launch-file`).

Run: ros2 launch {launch_name}
Every component is a `fmionnx node` process speaking ROS 2 on Cyclone DDS; use the same
ROS_DOMAIN_ID / ROS_LOCALHOST_ONLY as the ROS 2 nodes it talks to.
"""

import os

from launch import LaunchDescription
from launch.actions import ExecuteProcess

HERE = os.path.dirname(os.path.abspath(__file__))
SYSTEM = {system_expr}
DISTRO = {distro!r}

NODES = [
{node_rows}
]


def generate_launch_description():
    """One process per component: `fmionnx node SYSTEM COMPONENT --sync free`."""
    return LaunchDescription(
        [
            ExecuteProcess(
                cmd=["fmionnx", "node", SYSTEM, component, "--sync", "free",
                     "--ros-distro", DISTRO],
                name=node_name,
                output="screen",
            )
            for component, node_name in NODES
        ]
    )
'''


def launch_file_text(plan: Ros2Plan, system_name: str, source: Path, target: Path) -> str:
    """The text of the launch file ``target`` for the system compiled from ``source``."""
    try:
        relative = os.path.relpath(source.resolve(), target.resolve().parent)
        system_expr = f"os.path.join(HERE, {relative!r})"
    except ValueError:  # another drive: keep the absolute path
        system_expr = repr(str(source.resolve()))
    rows = "\n".join(f"    ({n.component!r}, {n.name!r})," for n in plan.nodes)
    return _TEMPLATE.format(
        name=system_name,
        launch_name=target.name,
        system_expr=system_expr,
        distro=plan.distro.value,
        node_rows=rows,
    )
