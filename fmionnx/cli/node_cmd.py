"""``fmionnx node``: run one component of a system as a ROS 2 node (the supervisor starts these).

The node's options follow the rules ``fmionnx run --backend ros2`` checks them by
(:mod:`fmionnx.backends.ros2.backend`), with the same messages; ``--param`` is read as
``fmionnx run`` reads it.
"""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.run_options import MaxSteps, OnNonfinite, Param, Profile, RosDistro, StopTime
from fmionnx.core.steps import MAX_RUN_STEPS

if TYPE_CHECKING:
    from fmionnx.backends.ros2.node import Node
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.pipeline.request import ParamValue

System = Annotated[
    Path,
    typer.Argument(
        help="System file (.yaml, .ssp), or a compiled system (.fmionnx.json, from `fmionnx "
        "compile`)."
    ),
]
Component = Annotated[str, typer.Argument(help="The component this node runs.")]
Sync = Annotated[str, typer.Option("--sync", help="`lockstep` or `free`.")]
Rtf = Annotated[
    float | None,
    typer.Option("--rtf", help="Free run: the simulator node's pace (x real time, default 1)."),
]
RecordDir = Annotated[
    Path | None, typer.Option("--record-dir", help="Folder for this node's recorded rows.")
]
Supervised = Annotated[
    bool, typer.Option("--supervised", help="Started by `fmionnx run --backend ros2`.")
]
NodeMiddleware = Annotated[
    str,
    typer.Option(
        "--middleware",
        help="`dds` (Cyclone DDS), `rclpy` (a ROS 2 node) or `zenoh` (the rmw_zenoh wire).",
    ),
]
NodeInputWait = Annotated[
    float | None,
    typer.Option(
        "--input-wait",
        help="Free run: seconds a step waits for an input sample of its time (default 0.1).",
    ),
]
Remap = Annotated[
    list[str] | None,
    typer.Option("--remap", "-r", help="`/from:=/to`: publish or subscribe topic /from as /to."),
]
NodeRouter = Annotated[
    str,
    typer.Option(
        "--zenoh-router",
        help="With --middleware zenoh: the router endpoint (default: the Zenoh configuration's, "
        "tcp/localhost:7447 unless ZENOH_SESSION_CONFIG_URI or ZENOH_CONFIG_OVERRIDE say "
        "otherwise).",
    ),
]
ClockSource = Annotated[
    bool,
    typer.Option(
        "--clock-source",
        help="Free run of a system without a simulator, with no supervisor: this node publishes "
        "/clock at --rtf times real time (`fmionnx ros2 launch-file` sets it on one node).",
    ),
]
Models = Annotated[
    Path | None,
    typer.Option(
        "--models",
        help="Compiled system only: folder holding the models by content hash (`fmionnx "
        "compile --models`); default: where they were compiled.",
    ),
]


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


def _free_run_only(
    sync: str, supervised: bool, *, rtf: float | None, input_wait: float | None
) -> None:
    """Refuse ``--rtf`` and ``--input-wait`` in lockstep, as ``fmionnx run --backend ros2``
    does: a lockstep node steps when told, so a pace it silently ignored would read as
    honoured. The supervisor hands every node its own (checked) ``--rtf``, lockstep or not,
    so a ``--supervised`` node is not asked."""
    from fmionnx.runtime.backend import OptionsError

    if sync == "free" or supervised:
        return
    if rtf is not None:
        raise OptionsError("--rtf applies to --sync free only (lockstep is not paced)")
    if input_wait is not None:
        raise OptionsError("--input-wait applies to --sync free only")


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx node systems/sign_follower.yaml tracker --sync free\n\n"
    "  ROS_DOMAIN_ID=7 fmionnx node systems/sign_follower.yaml detector --ros-distro jazzy\n\n"
    "  fmionnx node robot.fmionnx.json tracker --models models/   # compiled elsewhere\n\n"
    "  fmionnx node systems/sign_follower.yaml tracker --middleware zenoh",
)
def node(
    system: System,
    component: Component,
    sync: Sync = "free",
    ros_distro: RosDistro = None,
    stop_time: StopTime = None,
    param: Param = None,
    rtf: Rtf = None,
    record_dir: RecordDir = None,
    supervised: Supervised = False,
    middleware: NodeMiddleware = "dds",
    input_wait: NodeInputWait = None,
    remap: Remap = None,
    zenoh_router: NodeRouter = "",
    models: Models = None,
    max_steps: MaxSteps = MAX_RUN_STEPS,
    profile: Profile = False,
    on_nonfinite: OnNonfinite = None,
    clock_source: ClockSource = False,
) -> None:
    """Run one component as a ROS 2 node (Cyclone DDS, rclpy or Zenoh); exit 0 at the stop time,
    1 on a fault, 2 on a usage error, 3 when its model ended the simulation (docs/ros2.md)."""
    from fmionnx.backends.ros2.backend import (
        INPUT_WAIT,
        MIDDLEWARES,
        SYNC_MODES,
        checked_choice,
        checked_distro,
        checked_input_wait,
        checked_router,
        checked_rtf,
    )
    from fmionnx.pipeline.errors import RequestError
    from fmionnx.pipeline.request import params_from_text
    from fmionnx.runtime.backend import OptionsError

    try:  # the same rules as `fmionnx run --backend ros2`
        checked_choice(sync, "--sync", SYNC_MODES)
        checked_choice(middleware, "--middleware", MIDDLEWARES)
        checked_distro(ros_distro)
        _free_run_only(sync, supervised, rtf=rtf, input_wait=input_wait)
        rtf = checked_rtf(1.0 if rtf is None else rtf)
        input_wait = checked_input_wait(INPUT_WAIT if input_wait is None else input_wait)
        if zenoh_router and middleware != "zenoh":
            raise OptionsError("--zenoh-router applies to --middleware zenoh")  # noqa: TRY301
        if zenoh_router:
            checked_router(zenoh_router, endpoint_only=True)
        if clock_source and (sync != "free" or supervised):
            msg = (
                "--clock-source applies to --sync free without --supervised (a supervisor "
                "sends /clock itself)"
            )
            raise OptionsError(msg)  # noqa: TRY301
        values = params_from_text(param or [])
    except (OptionsError, RequestError) as exc:
        raise _fail(str(exc), ExitCode.USAGE) from None
    if max_steps < 1:
        raise _fail("--max-steps must be at least 1", ExitCode.USAGE)
    if on_nonfinite not in (None, "fault", "warn"):
        raise _fail(
            f"--on-nonfinite must be `fault` or `warn`, not `{on_nonfinite}`", ExitCode.USAGE
        )
    request = _NodeRequest(
        sync, ros_distro, middleware, record_dir, supervised, rtf, input_wait, zenoh_router,
        _remaps(remap or []), profile, on_nonfinite or "fault", clock_source,
    )  # fmt: skip
    logging.basicConfig(
        level=logging.INFO,
        stream=sys.stderr,
        format=f"%(asctime)s {component} %(levelname)s %(message)s",
    )
    from fmionnx.cli.outputs import check_output_folder
    from fmionnx.pipeline.outputs import undone_on_failure

    with undone_on_failure():  # a --record-dir made here goes again if the node cannot start
        if record_dir is not None:  # before the run: its rows are written only at its end
            check_output_folder(record_dir, "--record-dir")
        code = _run_node(system, component, request, values, stop_time, models,
                         max_steps=max_steps)  # fmt: skip
    raise typer.Exit(code)


@dataclass(frozen=True)
class _NodeRequest:
    """The node's options as given; the distribution is settled once the system is known."""

    sync: str
    ros_distro: str | None
    middleware: str
    record_dir: Path | None
    supervised: bool
    rtf: float
    input_wait: float
    zenoh_router: str
    remaps: tuple[tuple[str, str], ...]
    profile: bool = False
    on_nonfinite: str = "fault"
    clock_source: bool = False


def _run_node(
    path: Path,
    component: str,
    request: _NodeRequest,
    values: dict[str, ParamValue],
    stop_time: float | None,
    models: Path | None,
    *,
    max_steps: int,
) -> int:
    """Load the system, settle the distribution, run the node; its exit status."""
    from fmionnx import api
    from fmionnx.backends.ros2.env import Ros2EnvError
    from fmionnx.backends.ros2.node import NodeError
    from fmionnx.backends.ros2.rclpy_env import RclpyUnavailableError
    from fmionnx.backends.ros2.transport import TransportError
    from fmionnx.compile.systemfile import CompiledFileError
    from fmionnx.core.errors import DiagnosticError

    try:
        loaded = api.load(path, models=models)
        compiled = loaded.with_overrides(stop_time=stop_time, params=values).compiled
        if not request.supervised and compiled.run.steps > max_steps:  # `run` checked its own
            raise _fail(
                f"the run is {compiled.run.steps:.3g} base steps, more than --max-steps "
                f"{max_steps:.3g}; check the stop time and step, or pass a larger --max-steps",
                ExitCode.USAGE,
            )
        the_node = _made_node(compiled, component, request)
        logging.getLogger("fmionnx.node").info(
            "system %s, content hash %s", compiled.name, compiled.content_hash[:16]
        )
        from fmionnx.runtime.lifetime import models_here

        with models_here():  # what the node's model starts ends with the node
            return the_node.run()
    except DiagnosticError as exc:
        lines = "; ".join(str(d.message) for d in exc.diagnostics[:3])
        raise _fail(f"{path}: {lines}", ExitCode.PROBLEMS) from None
    except (NodeError, api.OverrideError) as exc:  # COMPONENT, --param, --stop-time: as `run`
        raise _fail(str(exc), ExitCode.USAGE) from None
    except (CompiledFileError, Ros2EnvError, TransportError, RclpyUnavailableError) as exc:
        raise _fail(str(exc), ExitCode.PROBLEMS) from None
    except KeyboardInterrupt:
        raise _fail("interrupted", 130) from None


def _made_node(compiled: CompiledSystem, component: str, request: _NodeRequest) -> Node:
    """The node of ``component``, for ``--ros-distro`` else the system's own distribution."""
    from fmionnx.backends.ros2.loading import plan_for, resolve_distro
    from fmionnx.backends.ros2.middleware import Middleware
    from fmionnx.backends.ros2.node import Node, NodeOptions, SyncMode
    from fmionnx.backends.ros2.rclpy_env import distro_problem
    from fmionnx.compile.ros2.messages import RosDistro as Distro

    # Checked in `node` already (checked_choice, checked_distro): these cannot fail.
    mode, transport = SyncMode(request.sync), Middleware(request.middleware)
    wanted = Distro(request.ros_distro) if request.ros_distro is not None else None
    distro = resolve_distro(compiled, wanted)  # --ros-distro, else the system's own
    problem = distro_problem(distro) if transport is Middleware.RCLPY else None
    if problem is not None:
        raise _fail(f"--middleware rclpy: {problem}", ExitCode.USAGE)
    options = NodeOptions(
        mode, distro, request.record_dir, request.supervised, request.rtf, transport,
        input_wait=request.input_wait, remap=request.remaps, zenoh_router=request.zenoh_router,
        profile=request.profile, on_nonfinite=request.on_nonfinite,
        clock_source=request.clock_source,
    )  # fmt: skip
    return Node(compiled, plan_for(compiled, distro), component, options)
