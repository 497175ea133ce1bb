"""The options of ``fmionnx run`` (and those ``fmionnx node`` shares), declared once.

Each is an ``Annotated`` alias (Hamilton's ``cli/__main__.py`` style): a command's signature
lists its options in one line each, and the help text of an option is written once. Values
are passed on unchecked: :func:`fmionnx.pipeline.request.build_request` and the backends'
options types check them, for the CLI and the Python API alike. ``None`` means "not given".
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from fmionnx.core.steps import MAX_RUN_STEPS
from fmionnx.pipeline.defaults import CHECKPOINT_EVERY, STEP_TIMEOUT

Target = Annotated[
    Path,
    typer.Argument(
        help="System file (.yaml, .ssp, .ssd, or a compiled .fmionnx.json), or a single model: "
        ".fmu or .onnx."
    ),
]


def folder_path(text: str) -> Path:
    """``--out``'s folder; an empty one is refused here, where it is still text: as a path it
    is ``.``, and the run or sweep refused the current folder's files instead (a bug hunt)."""
    if not text:
        from fmionnx.cli.app import fail

        raise fail("--out is empty: name a results folder, e.g. `--out results`")
    return Path(text)


Out = Annotated[
    Path | None,
    typer.Option(
        "--out",
        "-o",
        parser=folder_path,
        metavar="<path>",
        help="Folder for results.csv, run.json and plots (default: out/<system name>/). "
        "Single ONNX model: one .npy per output (default: none).",
    ),
]
NoOut = Annotated[
    bool,
    typer.Option("--no-out", help="Write no results at all (e.g. to time or smoke-test a run)."),
]
StopTime = Annotated[
    float | None,
    typer.Option(
        "--stop-time",
        help="Stop time in seconds; replaces the system file's `run.stop` (a single FMU: its "
        "default experiment's stop time).",
    ),
]
Param = Annotated[
    list[str] | None,
    typer.Option(
        "--param",
        "-p",
        help="Parameter or start value set before initialization, repeatable; the value is read "
        "as JSON. A system: `component.name=value` (`-p tracker.turnRate=0.6`); a single FMU: "
        "`name=value` (`-p k=2`). A single ONNX model: an input's value, by its name "
        "(`-p k=[0.5]`; --input reads one from a .npy file).",
    ),
]
Quiet = Annotated[
    bool,
    typer.Option(
        "--quiet",
        "-q",
        help="No progress bar, warnings or summary; the last line `Results: <folder>` stays.",
    ),
]
Record = Annotated[
    Path | None,
    typer.Option(
        "--record",
        help="Also write an MCAP file. In-process: camera frames and the recorded signals; with "
        "--backend ros2: every topic as it crossed the wire.",
    ),
]
Step = Annotated[
    float | None,
    typer.Option(
        "--step",
        help="Base (communication) step in seconds; replaces `run.step` and is checked like it "
        "(default: the system file's, else the fastest period, else the models' default "
        "experiment step).",
    ),
]
StartTime = Annotated[
    float | None,
    typer.Option(
        "--start-time", help="Start time in seconds; replaces `run.start` (a single FMU: 0)."
    ),
]
OutputInterval = Annotated[
    float | None,
    typer.Option(
        "--output-interval",
        help="Seconds between two rows of results.csv, a whole multiple of the step; replaces "
        "`run.output_interval` (default: every step). The last point is always written.",
    ),
]
Interface = Annotated[
    str | None,
    typer.Option(
        "--interface",
        help="Single FMU only: `cs` (co-simulation) or `me` (model exchange); default: "
        "co-simulation when the FMU offers it.",
    ),
]
Inputs = Annotated[
    list[str] | None,
    typer.Option(
        "--input", "-i", help="Single ONNX model only: `name=file.npy` per input, repeatable."
    ),
]
Backend = Annotated[
    str,
    typer.Option(
        "--backend",
        help="`inprocess`: one deterministic process. `ros2`: one ROS 2 node process per "
        "component, from the same system file (system files only).",
    ),
]
Sync = Annotated[
    str | None,
    typer.Option(
        "--sync", help="With --backend ros2: `lockstep` (reproducible) or `free` (paced)."
    ),
]
RosDistro = Annotated[
    str | None,
    typer.Option(
        "--ros-distro",
        help="With --backend ros2: humble, iron, jazzy or kilted (wire types); replaces the "
        "system file's `ros2: distro:` (default: that, else jazzy).",
    ),
]
Middleware = Annotated[
    str | None,
    typer.Option(
        "--middleware",
        help="With --backend ros2: `dds` (Cyclone DDS), `rclpy` (ROS 2's own) or `zenoh` (the "
        "rmw_zenoh wire).",
    ),
]
ZenohRouter = Annotated[
    str | None,
    typer.Option(
        "--zenoh-router",
        help="With --middleware zenoh: `auto` (the configured router, tcp/localhost:7447 by "
        "default, when it answers; else one started for the run) or an endpoint such as "
        "`tcp/10.0.0.2:7447`.",
    ),
]
Rtf = Annotated[
    float | None,
    typer.Option(
        "--rtf",
        help="Pace the run to X times real time (0: as fast as it goes). In-process: every base "
        "step waits for its moment; late steps, the largest lateness and where an overrun's time "
        "went are reported, and a run that falls behind says so (default 0). With --backend "
        "ros2 --sync free: the simulator's pace (default 1).",
    ),
]
Profile = Annotated[
    bool,
    typer.Option(
        "--profile",
        help="Time every component's phases (instantiate, initialize, transfer, render, step or "
        "infer, record): a table sorted by share of the loop, and run.json's `statistics`.",
    ),
]
OnNonfinite = Annotated[
    str | None,
    typer.Option(
        "--on-nonfinite",
        help="A NaN or infinity leaving a component on a connection: `fault` (default: the run "
        "stops, naming component, port and time) or `warn` (noted once per connection, passed on).",
    ),
]
View = Annotated[
    list[str] | None,
    typer.Option(
        "--view",
        help="Show the run live: `rerun` (spawns a Rerun viewer, or connects to the local one), "
        "`rerun+tcp://HOST:PORT` (a remote viewer), `foxglove` (Foxglove WebSocket on "
        "localhost:8765) or `foxglove:PORT`; repeatable. Needs the `view` extra "
        "(docs/viewing.md).",
    ),
]
Rrd = Annotated[
    Path | None,
    typer.Option(
        "--rrd",
        help="Write the run as a Rerun recording (.rrd) without a viewer: frames, signals, the "
        "course, the graph and the checks on the simulation timeline.",
    ),
]
InputWait = Annotated[
    float | None,
    typer.Option(
        "--input-wait",
        help="With --backend ros2 --sync free: seconds a node's step waits for an input sample "
        "of its time before stepping on an older one (default 0.1).",
    ),
]
StepTimeout = Annotated[
    float,
    typer.Option(
        "--step-timeout",
        help="Seconds one step of a component may take before the run stops with a fault "
        "(in-process and ROS 2 lockstep).",
    ),
]
Isolate = Annotated[
    list[str] | None,
    typer.Option(
        "--isolate",
        help="In-process: components whose models run in a process of their own, so a crash or "
        "hang cannot take the run down: `fmus` (every FMU), `all`, `none`, or component names "
        "(repeat the option or separate by commas); `guardian`: the whole run in one guarded "
        "process instead. Default: `guardian` for a lone FMU (on Linux, without --sandbox, "
        "--record, --view or --rrd), else `fmus` (docs/running.md).",
    ),
]
Sandbox = Annotated[
    bool,
    typer.Option(
        "--sandbox",
        help="In-process: confine isolated models (no network, nothing writable but their own "
        "folder; Linux Landlock and namespaces).",
    ),
]
Schedule = Annotated[
    str | None,
    typer.Option(
        "--schedule",
        help="In-process: `parallel` (default) runs steps that may overlap others (ONNX models, "
        "isolated components) on a second core, bit-identical to `sequential`, which runs every "
        "step on one thread.",
    ),
]
CheckpointEvery = Annotated[
    float,
    typer.Option(
        "--checkpoint-every",
        help="With --out: rewrite results.csv and run.json (status `running`) at least this "
        "many seconds apart while the run goes on, so a killed run keeps its results.",
    ),
]
Force = Annotated[
    bool,
    typer.Option(
        "--force",
        help="Write into a results folder (--out or the default) that holds files fmionnx did "
        "not write; only the run's own files are replaced.",
    ),
]
Checks = Annotated[
    bool,
    typer.Option(
        "--checks/--no-checks",
        help="Evaluate the system's `checks:` after the run: print them, record them in "
        "run.json, exit 1 when one fails (--no-checks: a shortened or exploratory run).",
    ),
]
MaxSteps = Annotated[
    int,
    typer.Option("--max-steps", help="Refuse runs of more base steps than this (default 10^10)."),
]
Plot = Annotated[
    bool,
    typer.Option(
        "--plot",
        help="Also draw every recorded signal over time into signals.png in the results folder "
        "(one panel per port, labelled with its unit); any run, a single FMU too.",
    ),
]

__all__ = [
    "CHECKPOINT_EVERY",
    "MAX_RUN_STEPS",
    "STEP_TIMEOUT",
]
