"""``fmionnx node``: run one component of a system as a ROS 2 node (the supervisor starts these)."""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app
from fmionnx.core.steps import MAX_RUN_STEPS


def _fail(message: str, code: int) -> typer.Exit:
    print(f"error: {message}", file=sys.stderr)
    return typer.Exit(code)


def _remaps(items: list[str]) -> tuple[tuple[str, str], ...]:
    """``--remap /from:=/to`` pairs, both valid absolute ROS topic names (usage error else)."""
    from fmionnx.compile.ros2.names import topic_problem

    pairs = []
    for item in items:
        source, sep, target = item.partition(":=")
        if not sep:
            raise _fail(f"--remap `{item}` must look like `/from:=/to`", ExitCode.USAGE)
        for name in (source, target):
            problem = topic_problem(name)
            if problem is not None:
                raise _fail(f"--remap `{item}`: `{name}` is no topic name: {problem}",
                            ExitCode.USAGE)  # fmt: skip
        pairs.append((source, target))
    return tuple(pairs)


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx node systems/sign_follower.yaml tracker --sync free\n\n"
    "  ROS_DOMAIN_ID=7 fmionnx node systems/sign_follower.yaml detector --ros-distro jazzy\n\n"
    "  fmionnx node robot.fmionnx.json tracker --models models/   # compiled elsewhere\n\n"
    "  fmionnx node systems/sign_follower.yaml tracker --middleware zenoh",
)
def node(
    system: Annotated[
        Path,
        typer.Argument(
            help="System file (.yaml, .ssp), or a compiled system (.fmionnx.json, from "
            "`fmionnx compile`)."
        ),
    ],
    component: Annotated[str, typer.Argument(help="The component this node runs.")],
    sync: Annotated[str, typer.Option("--sync", help="`lockstep` or `free`.")] = "free",
    ros_distro: Annotated[
        str | None,
        typer.Option(
            "--ros-distro",
            help="humble, iron, jazzy or kilted; replaces the system's `ros2: distro:` "
            "(default: that, else jazzy).",
        ),
    ] = None,
    stop_time: Annotated[
        float | None, typer.Option("--stop-time", help="Stop time in seconds (overrides).")
    ] = None,
    param: Annotated[
        list[str] | None, typer.Option("--param", "-p", help="`component.name=value`.")
    ] = None,
    rtf: Annotated[
        float, typer.Option("--rtf", help="Free run: the simulator node's pace (x real time).")
    ] = 1.0,
    record_dir: Annotated[
        Path | None, typer.Option("--record-dir", help="Folder for this node's recorded rows.")
    ] = None,
    supervised: Annotated[
        bool, typer.Option("--supervised", help="Started by `fmionnx run --backend ros2`.")
    ] = False,
    middleware: Annotated[
        str,
        typer.Option(
            "--middleware",
            help="`dds` (Cyclone DDS), `rclpy` (a ROS 2 node) or `zenoh` (the rmw_zenoh wire).",
        ),
    ] = "dds",
    input_wait: Annotated[
        float,
        typer.Option(
            "--input-wait",
            help="Free run: seconds a step waits for an input sample of its time (default 0.1).",
        ),
    ] = 0.1,
    remap: Annotated[
        list[str] | None,
        typer.Option(
            "--remap", "-r", help="`/from:=/to`: publish or subscribe topic /from as /to."
        ),
    ] = None,
    zenoh_router: Annotated[
        str,
        typer.Option(
            "--zenoh-router",
            help="With --middleware zenoh: the router endpoint (default: the Zenoh "
            "configuration's, tcp/localhost:7447 unless ZENOH_SESSION_CONFIG_URI or "
            "ZENOH_CONFIG_OVERRIDE say otherwise).",
        ),
    ] = "",
    models: Annotated[
        Path | None,
        typer.Option(
            "--models",
            help="Compiled system only: folder holding the models by content hash "
            "(`fmionnx compile --models`); default: where they were compiled.",
        ),
    ] = None,
    max_steps: Annotated[
        int,
        typer.Option(
            "--max-steps", help="Refuse runs of more base steps than this (default 10^10)."
        ),
    ] = MAX_RUN_STEPS,
) -> None:
    """Run one component as a ROS 2 node (Cyclone DDS, rclpy or Zenoh); exit 0 at the stop time,
    1 on a fault, 3 when its model ended the simulation (docs/ros2.md)."""
    from fmionnx import api
    from fmionnx.backends.ros2.env import Ros2EnvError
    from fmionnx.backends.ros2.loading import plan_for, resolve_distro
    from fmionnx.backends.ros2.middleware import Middleware
    from fmionnx.backends.ros2.node import Node, NodeError, NodeOptions, SyncMode
    from fmionnx.backends.ros2.rclpy_env import RclpyUnavailableError, distro_problem
    from fmionnx.backends.ros2.transport import TransportError
    from fmionnx.compile.ros2.messages import RosDistro
    from fmionnx.compile.systemfile import CompiledFileError
    from fmionnx.core.errors import DiagnosticError

    try:
        mode = SyncMode(sync)
        requested = None if ros_distro is None else RosDistro(ros_distro)
        transport = Middleware(middleware)
    except ValueError as exc:
        raise _fail(str(exc), ExitCode.USAGE) from None
    if not rtf >= 0:  # also NaN
        raise _fail("--rtf must be >= 0 (0: as fast as possible)", ExitCode.USAGE)
    if max_steps < 1:
        raise _fail("--max-steps must be at least 1", ExitCode.USAGE)
    if not 0 <= input_wait < float("inf"):  # also NaN
        raise _fail("--input-wait must be >= 0 seconds", ExitCode.USAGE)
    remaps = _remaps(remap or [])
    if zenoh_router and transport is not Middleware.ZENOH:
        raise _fail("--zenoh-router applies to --middleware zenoh", ExitCode.USAGE)
    if zenoh_router:
        from fmionnx.backends.ros2.zenoh.router import router_problem

        wrong = router_problem(zenoh_router)
        if wrong is not None or zenoh_router == "auto":
            raise _fail(wrong or "--zenoh-router of a node is an endpoint, not `auto`",
                        ExitCode.USAGE)  # fmt: skip
    params = {}
    for item in param or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise _fail(f"--param `{item}` must look like `name=value`", ExitCode.USAGE)
        params[key.strip()] = value.strip()
    logging.basicConfig(
        level=logging.INFO,
        stream=sys.stderr,
        format=f"%(asctime)s {component} %(levelname)s %(message)s",
    )
    try:
        values = {k: api.parse_value(v) for k, v in params.items()}
        loaded = api.load(system, models=models)
        compiled = loaded.with_overrides(stop_time=stop_time, params=values).compiled
        if not supervised and compiled.run.steps > max_steps:  # `run` checked its own nodes
            raise _fail(
                f"the run is {compiled.run.steps:.3g} base steps, more than --max-steps "
                f"{max_steps:.3g}; check the stop time and step, or pass a larger --max-steps",
                ExitCode.USAGE,
            )
        distro = resolve_distro(compiled, requested)  # --ros-distro, else the system's own
        problem = distro_problem(distro) if transport is Middleware.RCLPY else None
        if problem is not None:
            raise _fail(f"--middleware rclpy: {problem}", ExitCode.USAGE)
        plan = plan_for(compiled, distro)
        options = NodeOptions(
            mode,
            distro,
            record_dir,
            supervised,
            rtf,
            transport,
            input_wait=input_wait,
            remap=remaps,
            zenoh_router=zenoh_router,
        )
        the_node = Node(compiled, plan, component, options)
        logging.getLogger("fmionnx.node").info(
            "system %s, content hash %s", compiled.name, compiled.content_hash[:16]
        )
        code = the_node.run()
    except DiagnosticError as exc:
        lines = "; ".join(str(d.message) for d in exc.diagnostics[:3])
        raise _fail(f"{system}: {lines}", ExitCode.PROBLEMS) from None
    except (
        NodeError,
        api.OverrideError,
        CompiledFileError,
        Ros2EnvError,
        TransportError,
        RclpyUnavailableError,
    ) as exc:
        raise _fail(str(exc), ExitCode.PROBLEMS) from None
    except KeyboardInterrupt:
        raise _fail("interrupted", 130) from None
    raise typer.Exit(code)
