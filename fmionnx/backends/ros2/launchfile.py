"""A ROS 2 Python launch file running every node of a system (``fmionnx ros2 launch-file``).

One ``ExecuteProcess`` per non-external component, each ``fmionnx node SYSTEM COMPONENT --sync
free`` (``--middleware zenoh``: on the rmw_zenoh wire, with ``RMW_IMPLEMENTATION=rmw_zenoh_cpp``
for the workspace's own nodes): without a supervisor the simulator node is the clock (it
starts once the readers of its topics matched) and every other node follows ``/clock``. A
system without any simulator has no such node, and its nodes waited for a ``/clock`` nobody
sent: there the first node in the step order gets ``--clock-source`` and is the clock (a
``run --backend ros2 --sync free`` has its supervisor send it instead). The system file is
referenced relative to the launch file when it can be, so the pair can move together.
"""

from __future__ import annotations

import os
from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.kinds.base import SIMULATOR
from fmionnx.kinds.registry import has_capability

_TEMPLATE = '''"""ROS 2 launch file for the fmionnx system `{name}` (written by `fmionnx ros2 launch-file`).

Run: ros2 launch {launch_name}
{wire_doc}
"""

import os

from launch import LaunchDescription
from launch.actions import ExecuteProcess

HERE = os.path.dirname(os.path.abspath(__file__))
SYSTEM = {system_expr}
DISTRO = {distro!r}
MIDDLEWARE = {middleware!r}
#: Added to the environment of every process (ROS 2 tools and nodes started with them follow it).
ENV = {env!r}

NODES = [
{node_rows}
]

{clock_doc}
CLOCK = {clock!r}


def generate_launch_description():
    """One process per component: `fmionnx node SYSTEM COMPONENT --sync free`."""
    return LaunchDescription(
        [
            ExecuteProcess(
                cmd=["fmionnx", "node", SYSTEM, component, "--sync", "free",
                     "--ros-distro", DISTRO, "--middleware", MIDDLEWARE]
                + (["--clock-source"] if component == CLOCK else []),
                name=node_name,
                additional_env=ENV,
                output="screen",
            )
            for component, node_name in NODES
        ]
    )
'''


_WIRE_DOC = {
    "dds": "Every component is a `fmionnx node` process speaking ROS 2 on Cyclone DDS; use the "
    "same\nROS_DOMAIN_ID / ROS_LOCALHOST_ONLY as the ROS 2 nodes it talks to.",
    "zenoh": "Every component is a `fmionnx node` process speaking ROS 2 over Zenoh as rmw_zenoh "
    "does\n(RMW_IMPLEMENTATION=rmw_zenoh_cpp is set for every process); start the router first:\n"
    "ros2 run rmw_zenoh_cpp rmw_zenohd",
}
#: Environment of every process per wire.
_ENV = {"dds": {}, "zenoh": {"RMW_IMPLEMENTATION": "rmw_zenoh_cpp"}}


_CLOCK_DOC = {
    True: "#: The component whose node publishes /clock (`--clock-source`): the system has no "
    "simulator.",
    False: "#: No node is started with `--clock-source`: the simulator's node publishes /clock.",
}


def clock_stand_in(system: CompiledSystem, plan: Ros2Plan) -> str | None:
    """The component whose node the launch file makes the clock: None when a simulator is one
    of the components (its node is the clock; an ``external`` one, from outside), else the
    first node in the step order."""
    if any(has_capability(c, SIMULATOR) for c in system.components):
        return None
    running = {n.component for n in plan.nodes}
    return next((name for name in system.order if name in running), None)


def launch_file_text(
    plan: Ros2Plan,
    system: CompiledSystem,
    source: Path,
    target: Path,
    middleware: str = "dds",
) -> str:
    """The text of the launch file ``target`` for ``system``, compiled from ``source``.

    ``middleware``: ``dds`` or ``zenoh`` (every node on the rmw_zenoh wire, and
    ``RMW_IMPLEMENTATION=rmw_zenoh_cpp`` for every process the file starts).
    """
    clock = clock_stand_in(system, plan)
    try:
        relative = os.path.relpath(source.resolve(), target.resolve().parent)
        system_expr = f"os.path.join(HERE, {relative!r})"
    except ValueError:  # another drive: keep the absolute path
        system_expr = repr(str(source.resolve()))
    rows = "\n".join(f"    ({n.component!r}, {n.name!r})," for n in plan.nodes)
    return _TEMPLATE.format(
        name=system.name,
        clock=clock,
        clock_doc=_CLOCK_DOC[clock is not None],
        launch_name=target.name,
        system_expr=system_expr,
        distro=plan.distro.value,
        node_rows=rows,
        middleware=middleware,
        env=_ENV[middleware],
        wire_doc=_WIRE_DOC[middleware],
    )
