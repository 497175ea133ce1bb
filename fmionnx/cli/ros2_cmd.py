"""``fmionnx ros2 graph | launch-file``: the live ROS 2 graph, and a launch file for ROS 2 users."""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.outputs import check_output_file, refuse_an_input, write_derived

ros2_app = typer.Typer(
    help="ROS 2 helpers: compare the live graph with a system, write a launch file.",
    no_args_is_help=True,
)
app.add_typer(ros2_app, name="ros2")

DistroOption = Annotated[
    str | None,
    typer.Option(
        "--ros-distro",
        help="humble, iron, jazzy or kilted; replaces the system file's `ros2: distro:` "
        "(default: that, else jazzy).",
    ),
]


def _fail(message: str, code: int) -> typer.Exit:
    print(f"error: {message}", file=sys.stderr)
    return typer.Exit(code)


def _plan(system: Path, distro: str | None) -> tuple[object, object]:
    """The compiled system and its plan for ``--ros-distro`` (None: the system's own)."""
    from fmionnx import api
    from fmionnx.backends.ros2.loading import plan_for
    from fmionnx.compile.ros2.messages import RosDistro
    from fmionnx.core.errors import DiagnosticError

    try:
        chosen = None if distro is None else RosDistro(distro)
    except ValueError:
        names = ", ".join(d.value for d in RosDistro)
        raise _fail(f"--ros-distro must be one of {names}", ExitCode.USAGE) from None
    try:
        compiled = api.load(system).compiled
        return compiled, plan_for(compiled, chosen)
    except DiagnosticError as exc:
        from fmionnx.reporters import FileResult
        from fmionnx.reporters.text import TextReporter

        TextReporter().render(
            [FileResult(system, tuple(exc.diagnostics))], sys.stderr, color=sys.stderr.isatty()
        )
        raise typer.Exit(ExitCode.PROBLEMS) from None


@ros2_app.command(
    epilog="Examples:\n\n"
    "  fmionnx ros2 graph systems/sign_follower.yaml --timeout 3\n\n"
    "  fmionnx ros2 graph systems/sign_follower.yaml --domain 42 --format json\n\n"
    "  fmionnx ros2 graph systems/sign_follower.yaml --middleware zenoh",
)
def graph(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp).")],
    domain: Annotated[
        int | None,
        typer.Option("--domain", help="ROS domain (default: ROS_DOMAIN_ID or 0)."),
    ] = None,
    timeout: Annotated[float, typer.Option("--timeout", help="Seconds to listen.")] = 2.0,
    ros_distro: DistroOption = None,
    output_format: Annotated[str, typer.Option("--format", "-f", help="text or json.")] = "text",
    middleware: Annotated[
        str,
        typer.Option(
            "--middleware",
            help="`dds`: read DDS discovery; `zenoh`: read rmw_zenoh's liveliness tokens.",
        ),
    ] = "dds",
    zenoh_router: Annotated[
        str,
        typer.Option(
            "--zenoh-router",
            help="With --middleware zenoh: the router endpoint (default: the Zenoh "
            "configuration's, tcp/localhost:7447).",
        ),
    ] = "",
) -> None:
    """Read the live graph (DDS discovery or Zenoh liveliness) and compare it with the system;
    exit 1 if links are missing or of another message type than the system's."""
    from fmionnx.backends.ros2.env import Ros2EnvError, from_environment
    from fmionnx.backends.ros2.graph import compare, read_live_graph, render_json, render_text
    from fmionnx.backends.ros2.transport import Participant, TransportError
    from fmionnx.compile.ros2.types import Ros2Plan

    if output_format not in ("text", "json"):
        raise _fail(f"--format must be `text` or `json`, not `{output_format}`", ExitCode.USAGE)
    _check_listening(timeout, domain)
    if middleware not in ("dds", "zenoh"):
        raise _fail(f"--middleware must be `dds` or `zenoh`, not `{middleware}`", ExitCode.USAGE)
    if zenoh_router and middleware != "zenoh":
        raise _fail("--zenoh-router applies to --middleware zenoh", ExitCode.USAGE)
    if zenoh_router:
        from fmionnx.backends.ros2.zenoh.router import router_problem

        problem = router_problem(zenoh_router)
        if problem is not None or zenoh_router == "auto":
            raise _fail(problem or "--zenoh-router is an endpoint here", ExitCode.USAGE)
    _, plan = _plan(system, ros_distro)
    assert isinstance(plan, Ros2Plan)
    environ = dict(os.environ)
    if domain is not None:
        environ["ROS_DOMAIN_ID"] = str(domain)
    try:
        if middleware == "zenoh":
            from fmionnx.backends.ros2.zenoh.config import zenoh_environment
            from fmionnx.backends.ros2.zenoh.graph import read_zenoh_graph

            zenv = zenoh_environment(plan.distro, environ, router=zenoh_router)
            live = read_zenoh_graph(zenv, max(timeout, 0.1))
        else:
            env = from_environment(plan.distro, environ)
            with Participant(env) as participant:
                live = read_live_graph(participant, max(timeout, 0.1))
    except (Ros2EnvError, TransportError) as exc:
        raise _fail(str(exc), ExitCode.PROBLEMS) from None
    result = compare(plan, live)
    render = render_json if output_format == "json" else render_text
    sys.stdout.write(render(plan, live, result))
    raise typer.Exit(ExitCode.OK if result.complete else ExitCode.PROBLEMS)


def _check_listening(timeout: float, domain: int | None) -> None:
    """``--timeout`` finite and > 0 (``inf`` listened for ever, a negative one was taken as
    0.1 s) and ``--domain`` a ROS domain id, refused by the option's name (exit 2): the
    environment check would name ``ROS_DOMAIN_ID``, which the user did not set."""
    from fmionnx.backends.ros2.env import MAX_DOMAIN_ID

    if not 0 < timeout < math.inf:  # also NaN
        raise _fail(f"--timeout must be a finite number of seconds > 0, not {timeout}",
                    ExitCode.USAGE)  # fmt: skip
    if domain is not None and not 0 <= domain <= MAX_DOMAIN_ID:
        raise _fail(f"--domain {domain} is out of range (expected 0 to {MAX_DOMAIN_ID})",
                    ExitCode.USAGE)  # fmt: skip


@ros2_app.command(
    "launch-file",
    epilog="Examples:\n\n  fmionnx ros2 launch-file systems/sign_follower.yaml -o robot.launch.py\n\n"
    "  fmionnx ros2 launch-file systems/sign_follower.yaml -o robot.launch.py --middleware zenoh",
)
def launch_file(
    system: Annotated[Path, typer.Argument(help="System file (.yaml, .ssp).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="The .launch.py to write.")],
    ros_distro: DistroOption = None,
    middleware: Annotated[
        str,
        typer.Option(
            "--middleware",
            help="`dds`, or `zenoh`: nodes on the rmw_zenoh wire and "
            "RMW_IMPLEMENTATION=rmw_zenoh_cpp for every process.",
        ),
    ] = "dds",
) -> None:
    """Write a ROS 2 Python launch file with one `fmionnx node` process per component."""
    from fmionnx.backends.ros2.launchfile import launch_file_text
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.compile.ros2.types import Ros2Plan

    if middleware not in ("dds", "zenoh"):
        raise _fail(f"--middleware must be `dds` or `zenoh`, not `{middleware}`", ExitCode.USAGE)
    compiled, plan = _plan(system, ros_distro)
    assert isinstance(plan, Ros2Plan)
    assert isinstance(compiled, CompiledSystem)
    text = launch_file_text(plan, compiled, system, output, middleware)
    check_output_file(output, "--output")
    refuse_an_input(output, [system, *(c.path for c in compiled.components)])
    write_derived(output, text)  # atomically, never through a link
    print(f"wrote {output} ({len(plan.nodes)} nodes)")
