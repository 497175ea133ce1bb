"""The ROS 2 backend: one node process per component, on DDS, rclpy or the rmw_zenoh wire.

Its options are checked here once, for ``fmionnx run --backend ros2``, for
``fmionnx.run(..., backend="ros2")`` and, value by value, for ``fmionnx node`` (which takes
the same ``--rtf``, ``--input-wait`` and ``--zenoh-router``): one set of rules, one set of
messages.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Self

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.core.diagnostics import Diagnostic
from fmionnx.core.types import is_number
from fmionnx.runtime.backend import (
    Backend,
    BackendOptions,
    OptionsError,
    RunContext,
    checked_rtf,
)
from fmionnx.runtime.result import RunOptions, RunResult

#: Seconds a free-running node's step waits for an input sample of its time (default).
INPUT_WAIT = 0.1
SYNC_MODES = ("lockstep", "free")
MIDDLEWARES = ("dds", "rclpy", "zenoh")


def checked_input_wait(value: object) -> float:
    """``--input-wait``: seconds >= 0, finite."""
    seconds = _number(value, "--input-wait")
    if not 0 <= seconds < math.inf:  # also NaN
        msg = "--input-wait must be >= 0 seconds"
        raise OptionsError(msg)
    return seconds


def checked_router(value: object, *, endpoint_only: bool = False) -> str:
    """``--zenoh-router``: ``auto`` (not for a node, which is given the run's endpoint) or an
    endpoint such as ``tcp/10.0.0.2:7447``."""
    from fmionnx.backends.ros2.zenoh.router import router_problem

    if not isinstance(value, str):
        msg = "--zenoh-router is `auto` or an endpoint such as `tcp/localhost:7447`"
        raise OptionsError(msg)
    problem = router_problem(value)
    if problem is None and endpoint_only and value == "auto":
        problem = "--zenoh-router of a node is an endpoint, not `auto`"
    if problem is not None:
        raise OptionsError(problem)
    return value


def _number(value: object, option: str) -> float:
    if not is_number(value):
        msg = f"{option} takes a number, not `{value}`"
        raise OptionsError(msg)
    return float(value)


def checked_distro(value: object) -> RosDistro | None:
    """``--ros-distro``: None (the system's own) or one of the distributions, listed when not."""
    if value is None:
        return None
    if value not in {d.value for d in RosDistro}:
        msg = f"--ros-distro must be one of {', '.join(d.value for d in RosDistro)}"
        raise OptionsError(msg)
    return RosDistro(str(value))


def checked_choice(value: object, option: str, choices: tuple[str, ...]) -> str:
    """``value`` is one of ``choices`` (``--sync``, ``--middleware``)."""
    if value not in choices:
        listed = ", ".join(f"`{c}`" for c in choices[:-1]) + f" or `{choices[-1]}`"
        msg = f"{option} must be {listed}, not `{value}`"
        raise OptionsError(msg)
    assert isinstance(value, str)
    return value


@dataclasses.dataclass(frozen=True)
class Ros2BackendOptions(BackendOptions):
    """``sync``, ``ros_distro``, ``middleware``, ``zenoh_router``, ``rtf``, ``input_wait``."""

    sync: str = "lockstep"
    #: None: the system file's ``ros2: distro:``, else the default.
    ros_distro: RosDistro | None = None
    middleware: str = "dds"
    zenoh_router: str = "auto"
    rtf: float = 1.0
    input_wait: float = INPUT_WAIT

    @classmethod
    def checked(cls, given: Mapping[str, object]) -> Self:
        """Every value checked; options of another mode refused (``--input-wait`` and
        ``--rtf`` are free runs' only: lockstep steps as fast as the slowest node, and a pace
        it silently ignored would read as honoured; ``--zenoh-router`` is Zenoh's)."""
        sync = checked_choice(given.get("sync", "lockstep"), "--sync", SYNC_MODES)
        distro = checked_distro(given.get("ros_distro"))
        middleware = checked_choice(given.get("middleware", "dds"), "--middleware", MIDDLEWARES)
        rtf = checked_rtf(given.get("rtf", 1.0))
        if "rtf" in given and sync != "free":
            msg = "--rtf applies to --backend ros2 --sync free only (lockstep is not paced)"
            raise OptionsError(msg)
        wait = INPUT_WAIT
        if "input_wait" in given:
            if sync != "free":
                msg = "--input-wait applies to --backend ros2 --sync free only"
                raise OptionsError(msg)
            wait = checked_input_wait(given["input_wait"])
        router = given.get("zenoh_router", "auto")
        if middleware != "zenoh" and router != "auto":
            msg = "--zenoh-router applies to --middleware zenoh"
            raise OptionsError(msg)
        router = checked_router(router)
        return cls(
            sync=sync, ros_distro=distro,
            middleware=middleware, zenoh_router=router, rtf=rtf, input_wait=wait,
        )  # fmt: skip

    def where(self) -> str:
        """`` as ROS 2 nodes (lockstep)``."""
        return f" as ROS 2 nodes ({self.sync})"


class Ros2Backend(Backend):
    """Runs ``system`` as ROS 2 nodes, one OS process per component (docs/ros2.md)."""

    name = "ros2"
    summary = "one ROS 2 node process per component, from the same system file"
    options_type = Ros2BackendOptions
    records_itself = True
    runs_single_models = False

    def prepare(
        self, system: CompiledSystem, options: BackendOptions, context: RunContext
    ) -> BackendOptions:
        """``--middleware rclpy``: rclpy must load here (checked in a child process, so that
        rclpy stays out of this one) and be of the run's distribution (``--ros-distro``, else
        the system file's)."""
        del context
        assert isinstance(options, Ros2BackendOptions)
        if options.middleware == "rclpy":
            from fmionnx.backends.ros2.loading import resolve_distro
            from fmionnx.backends.ros2.rclpy_env import distro_problem, rclpy_problem

            problem = rclpy_problem() or distro_problem(resolve_distro(system, options.ros_distro))
            if problem is not None:
                msg = f"--middleware rclpy: {problem}; or use `--middleware dds` (the default)"
                raise OptionsError(msg)
        return options

    def validate(self, system: CompiledSystem, options: BackendOptions) -> list[Diagnostic]:
        """Nothing beyond the plan, which the supervisor derives and refuses before any node
        starts (a DiagnosticError from :func:`~.supervisor.run_ros2`)."""
        del system, options
        return []

    def run(self, system: CompiledSystem, options: BackendOptions, run: RunOptions) -> RunResult:
        """Start the nodes, drive them to the stop time, merge their rows."""
        from fmionnx.backends.ros2.node import SyncMode
        from fmionnx.backends.ros2.supervisor import Ros2Options, run_ros2

        assert isinstance(options, Ros2BackendOptions)
        settings = Ros2Options(
            sync=SyncMode(options.sync), distro=options.ros_distro, out=run.out, rtf=options.rtf,
            step_timeout=run.step_timeout if run.step_timeout is not None else 60.0,
            record=run.record_file, middleware=options.middleware,
            input_wait=options.input_wait, zenoh_router=options.zenoh_router, run=run,
        )  # fmt: skip
        return run_ros2(system, settings)


__all__ = ["checked_rtf"]  # ``fmionnx node`` checks its ``--rtf`` by the same rule
