"""Exception hierarchy: exceptions are for bugs and I/O, user mistakes are diagnostics.

Each subpackage raises its own subclass so that callers can tell a broken model file from a
failed run. Structured fields carry what a message needs (see FMPy ``FMICallException``).
"""

from __future__ import annotations

from fmionnx.core.diagnostics import Diagnostic, ErrorCode


class FmionnxError(Exception):
    """Root of every exception fmionnx raises on purpose."""


class DiagnosticError(FmionnxError):
    """Raised by API entry points when a stage produced errors; carries all diagnostics."""

    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        self.diagnostics = diagnostics
        first = diagnostics[0].message if diagnostics else "unknown error"
        super().__init__(f"{len(diagnostics)} problem(s); first: {first}")


class ModelError(FmionnxError):
    """A model file (FMU, ONNX, MuJoCo XML) cannot be read or is not supported.

    ``code`` is a diagnostics code (``E010`` ... ``E017``) so the compiler can turn the
    exception into a diagnostic at the system file's location.
    """

    def __init__(self, code: ErrorCode, message: str, *, hint: str | None = None) -> None:
        self.code = code
        self.hint = hint
        super().__init__(message)


class BuildError(FmionnxError):
    """Compiling a source FMU failed; ``log`` holds the compiler output."""

    def __init__(self, message: str, log: str = "") -> None:
        self.log = log
        super().__init__(message)


class RunError(FmionnxError):
    """A run stopped on a fault: names the component, port and simulated time when known."""

    def __init__(
        self,
        message: str,
        *,
        component: str | None = None,
        port: str | None = None,
        time: float | None = None,
    ) -> None:
        self.component = component
        self.port = port
        self.time = time
        super().__init__(message)


class ModelTerminated(RunError):  # noqa: N818 - no error: the model's own end of the run
    """A model asked to end the simulation (FMI ``terminateSimulation``, ``fmi2Terminated``).

    Not a fault: the model finished what it simulates (a stop condition inside it). It is a
    RunError so that every layer passing faults on (isolation, ROS 2 nodes) carries it
    unchanged; the master catches it first and ends the run normally at the end of the step
    that asked (``docs/execution.md``). ``reason`` is the bare reason, without the
    ``component `x` at t=...`` prefix of the message.
    """

    def __init__(
        self,
        message: str,
        *,
        reason: str,
        component: str | None = None,
        port: str | None = None,
        time: float | None = None,
    ) -> None:
        self.reason = reason
        super().__init__(message, component=component, port=port, time=time)
