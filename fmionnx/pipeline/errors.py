"""What stops a run before its first step, each with the exit status the CLI gives it.

A fault *during* a run is not an exception: it is the run's status (``RunResult.status``),
and the results recorded up to it are written. These are the refusals before that: a request
that does not fit (usage, exit 2), a system the chosen backend cannot run (exit 1), a stop
signal that arrived first (130, 143). Errors of the system file itself are
:class:`~fmionnx.core.errors.DiagnosticError` (exit 1), rendered like ``validate``'s.
"""

from __future__ import annotations

from fmionnx.core.errors import FmionnxError

#: Exit statuses: 0 ok, 1 the system, its models or its checks are wrong, 2 usage.
EXIT_OK = 0
EXIT_PROBLEMS = 1
EXIT_USAGE = 2


class PipelineError(FmionnxError):
    """A run refused before it started; ``exit_status`` is what the CLI exits with."""

    exit_status = EXIT_PROBLEMS

    def __init__(self, message: str, exit_status: int | None = None) -> None:
        super().__init__(message)
        if exit_status is not None:
            self.exit_status = exit_status


class RequestError(PipelineError):
    """The request does not fit: an option's value, options that exclude each other, an
    output path that cannot be written (exit 2)."""

    exit_status = EXIT_USAGE


class RefusedError(PipelineError):
    """The backend refused to run the system (an external component in-process, a system
    that does not map onto ROS 2, DDS that cannot start): exit 1."""
