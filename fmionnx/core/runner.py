"""The one small interface every component kind's runner implements.

The master never converts values per step: at setup it asks each runner for the *buffers*
behind its ports (flat numpy arrays, stable for the whole run) and wires connections between
them once. A runner reads its input buffers when it steps and refreshes its output buffers
after each step. ``set_input``/``get_output`` are conveniences built on the same buffers for
benchmarks and tests that drive a runner by hand.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from fmionnx.core.errors import ModelTerminated, RunError
from fmionnx.core.types import Component

Buffer = npt.NDArray[np.generic]


@dataclass(frozen=True, slots=True)
class Wiring:
    """What a runner needs to know about the system around it, decided by the master.

    ``driven``: ports that connections write into (parameters among them become run-time
    inputs). ``sizes``: element counts arriving at each driven port (fixes symbolic ONNX dims).
    """

    driven: frozenset[str] = frozenset()
    sizes: Mapping[str, int] | None = None


class Runner(Protocol):
    """Runtime object of one component (FMU instance, ORT session, MuJoCo model + data).

    Life cycle: ``instantiate()`` -> ``setup(start, stop)`` (parameters and start values
    before initialization, then initialization) -> ``step(t, h)`` repeatedly ->
    ``terminate()``. ``lazy_outputs`` are outputs too expensive to refresh every step
    (camera images): the master calls ``produce(port)`` only when a consumer is due.
    """

    component: Component
    lazy_outputs: frozenset[str]

    def instantiate(self) -> None:
        """Load the model and create the instance (nothing is computed yet)."""
        ...

    def setup(self, start: float, stop: float) -> None:
        """Apply parameters/start values, initialize; outputs then hold their initial values."""
        ...

    def input_buffer(self, port: str) -> Buffer:
        """The flat array the runner reads ``port`` from at each step (write into it)."""
        ...

    def output_buffer(self, port: str) -> Buffer:
        """The flat array holding the newest value of output ``port`` (read from it)."""
        ...

    def step(self, t: float, h: float) -> None:
        """Advance from communication point ``t`` by ``h``; raise RunError on a fault."""
        ...

    def produce(self, port: str) -> None:
        """Refresh a lazy output (e.g. render a camera) for the current state."""
        ...

    def terminate(self) -> None:
        """End the run and free native resources; safe to call twice or after a fault."""
        ...


@runtime_checkable
class StateSaving(Protocol):
    """A runner that can repeat a step: iterated algebraic loops need it of every member.

    ``save_state(t)`` keeps the instance's state at communication point ``t`` (one slot: a
    later save replaces it); ``restore_state(t)`` goes back to it, output buffers included, so
    that the next ``step(t, h)`` starts from exactly the saved point. An FMU does this with
    FMI ``getFMUstate``/``setFMUstate``; a runner without state only restores its outputs.
    ``t`` is for fault messages.
    """

    def save_state(self, t: float) -> None:
        """Keep the current state (and output values) as the one to go back to."""
        ...

    def restore_state(self, t: float) -> None:
        """Go back to the state (and output values) of the last :meth:`save_state`."""
        ...


@runtime_checkable
class StartEvaluating(Protocol):
    """A runner whose outputs at the start time are computed from its inputs at the start time.

    A model without state (ONNX) has no initialization of its own: its outputs are a function
    of its inputs. Its initial outputs are therefore those of its start inputs, as an FMU's
    are after initialization, not those of its inputs' start values (all zeros, a black
    camera frame). Once every runner is set up, the backend hands it, in the execution order,
    the values its connections carry at the start time (producers earlier in the order already
    evaluated, a camera rendered at the initial state) and calls :meth:`evaluate_at_start`,
    before the first row is recorded or published. docs/execution.md, "Initial values".
    """

    def evaluate_at_start(self, start: float) -> None:
        """Compute the outputs from the inputs now in the input buffers (time ``start``)."""


@runtime_checkable
class Interruptible(Protocol):
    """A runner whose calls can be stopped from another thread (onnxruntime's terminate flag).

    The step-timeout watchdog (:mod:`fmionnx.runtime.watchdog`) asks such a runner to stop a
    call that overran instead of abandoning the whole process: the call under way then raises
    a RunError whose message is ``reason``, and the run ends as a fault like any other (its
    results written, the process kept). Native code that never looks at the request is
    abandoned as before.
    """

    def interrupt(self, reason: str) -> None:
        """Make the call under way (or the next one) raise a fault saying ``reason``."""
        ...


class OutputCopies:
    """Copies of a runner's output buffers, for :class:`StateSaving` runners to restore."""

    def __init__(self, buffers: Sequence[Buffer]) -> None:
        self._buffers = tuple(buffers)
        self._copies = tuple(np.array(b, copy=True) for b in self._buffers)

    def save(self) -> None:
        """Copy the buffers' current values."""
        for buffer, copy in zip(self._buffers, self._copies, strict=True):
            np.copyto(copy, buffer)

    def restore(self) -> None:
        """Write the saved values back into the buffers."""
        for buffer, copy in zip(self._buffers, self._copies, strict=True):
            np.copyto(buffer, copy)


#: Makes the runner of a component: the master and the ROS 2 node take one (the kind table's
#: :func:`fmionnx.kinds.registry.make_runner` by default; tests and isolation layers wrap it).
RunnerFactory = Callable[[Component, Wiring], Runner]


def set_input(runner: Runner, port: str, values: npt.ArrayLike) -> None:
    """Write ``values`` (any shape with the port's element count) into an input buffer."""
    buffer = runner.input_buffer(port)
    np.copyto(buffer, np.asarray(values).reshape(buffer.shape), casting="unsafe")


def get_output(runner: Runner, port: str) -> Buffer:
    """A copy of the newest value of ``port``, shaped like the port (scalars as shape ``()``)."""
    if port in runner.lazy_outputs:
        runner.produce(port)
    buffer = runner.output_buffer(port)
    shape = tuple(d if isinstance(d, int) else -1 for d in runner.component.port(port).shape)
    return buffer.reshape(shape).copy() if shape else buffer.reshape(()).copy()


def fault(runner_component: str, message: str, *, time: float, port: str | None = None) -> RunError:
    """A RunError with the uniform wording ``component `x` at t=1.23 s: ...``."""
    where = f"component `{runner_component}`"
    if port is not None:
        where += f", port `{port}`"
    return RunError(
        f"{where} at t={time:.6g} s: {message}", component=runner_component, port=port, time=time
    )


def terminated(runner_component: str, reason: str, *, time: float) -> ModelTerminated:
    """The model asked to end the run (not a fault): same wording as :func:`fault`."""
    return ModelTerminated(
        f"component `{runner_component}` at t={time:.6g} s: {reason}",
        reason=reason,
        component=runner_component,
        time=time,
    )
