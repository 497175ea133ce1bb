"""FMI 3.0 runners: co-simulation and model exchange.

What FMI 3 does its own way: a log-message callback handed to the instantiate function;
tolerance, start and stop time given to ``fmi3EnterInitializationMode``; sized types whose
get/set functions also take the number of values (an array has one value reference);
``fmi3DoStep`` reporting events, early return and a termination request; and, for model
exchange, ``fmi3GetContinuousStateDerivatives`` and ``fmi3UpdateDiscreteStates``.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fmionnx.core.cosim import CsCalls, NativeSteppable
from fmionnx.core.errors import ModelTerminated
from fmionnx.core.runner import terminated
from fmionnx.core.types import DType, Port
from fmionnx.kinds.fmu.clocks import UNSUPPORTED_PREFIX
from fmionnx.kinds.fmu.me import ModelExchange, VersionCalls, discrete_input
from fmionnx.kinds.fmu.rollback import FmuRollback
from fmionnx.kinds.fmu.runner import FMI_WARNING, FmuRunner, Stepper
from fmionnx.kinds.fmu.values import ValueFunctions

#: FMI 3 get/set functions: type name and C element type per dtype.
VALUES = ValueFunctions(
    prefix="fmi3",
    types={
        DType.FLOAT64: ("Float64", ctypes.c_double),
        DType.FLOAT32: ("Float32", ctypes.c_float),
        DType.INT8: ("Int8", ctypes.c_int8),
        DType.UINT8: ("UInt8", ctypes.c_uint8),
        DType.INT16: ("Int16", ctypes.c_int16),
        DType.UINT16: ("UInt16", ctypes.c_uint16),
        DType.INT32: ("Int32", ctypes.c_int32),
        DType.UINT32: ("UInt32", ctypes.c_uint32),
        DType.INT64: ("Int64", ctypes.c_int64),
        DType.UINT64: ("UInt64", ctypes.c_uint64),
        DType.BOOL: ("Boolean", ctypes.c_bool),
    },
    counts_values=True,
)


class Fmi3Runner(FmuRunner):
    """What FMI 3 co-simulation and model exchange share: instantiation and initialization."""

    values = VALUES

    def _instantiate_fmu(self) -> None:
        fmu = self._fmu
        self._guard("fmi3Instantiate", lambda: fmu.instantiate(logMessage=self._logger))

    def _logger(self, env: Any, status: int, category: Any, message: Any) -> None:
        self._log_message(status, message)

    def _initialize(self, start: float, stop: float) -> None:
        fmu = self._fmu
        tolerance = self.config.tolerance
        self._guard(
            "fmi3EnterInitializationMode",
            lambda: fmu.enterInitializationMode(
                tolerance=tolerance, startTime=start, stopTime=stop
            ),
        )
        self._call_all(self._initial_input_calls(), start)
        self._guard("fmi3ExitInitializationMode", fmu.exitInitializationMode)


class Fmi3CoSimulation(Fmi3Runner, FmuRollback, NativeSteppable):
    """FMI 3 co-simulation: one raw ``fmi3DoStep`` per step; ``terminateSimulation`` ends the run.

    Its prepared calls (:meth:`cs_calls`) are what the native kernel steps instead. It saves
    and restores its state for iterated algebraic loops (:mod:`.rollback`).
    """

    state_functions = ("fmi3GetFMUState", "fmi3SetFMUState", "fmi3FreeFMUState")

    _do_step_function: Callable[..., int]
    _do_step_tail: tuple[object, ...]
    advance_function = "fmi3DoStep"
    #: FMI 3 ends a run through ``terminateSimulation``, never through a discard.
    discard_may_end = False
    _calls: CsCalls | None = None

    def _new_fmu(self, md: Any, root: Path) -> Any:
        from fmpy.fmi3 import FMU3Slave

        return FMU3Slave(**self._fmpy_arguments(md.coSimulation, root))

    def _stepper(self, start: float, stop: float) -> Stepper:
        # doStep's output arguments, written by the FMU at every step
        self._event_needed = ctypes.c_bool()
        self._terminate_requested = ctypes.c_bool()
        self._early_return = ctypes.c_bool()
        self._last_time = ctypes.c_double()
        self._do_step_function = self._fmu.dll.fmi3DoStep
        self._do_step_tail = (
            True,  # noSetFMUStatePriorToCurrentPoint: nothing is ever rolled back
            ctypes.byref(self._event_needed),
            ctypes.byref(self._terminate_requested),
            ctypes.byref(self._early_return),
            ctypes.byref(self._last_time),
        )
        assert self._instance is not None
        self._calls = CsCalls(
            self._instance,
            tuple(self._set_calls),
            self._do_step_function,
            tuple(self._get_calls),
            (self._event_needed, self._terminate_requested, self._early_return, self._last_time),
        )
        return self._do_step

    def _do_step(self, t: float, h: float) -> None:
        status = self._do_step_function(self._instance, t, h, *self._do_step_tail)
        if status > FMI_WARNING:
            self._check("fmi3DoStep", status, t)
        ending = self.termination_requested(t, h)
        if ending is not None:
            raise ending

    def termination_requested(self, t: float, h: float) -> ModelTerminated | None:
        """After ``fmi3DoStep`` from ``t``: did the FMU set ``terminateSimulation``?

        The native kernel stops its group there and asks through this too.
        """
        if not self._terminate_requested.value:
            return None
        return terminated(self.component.name, "the FMU requested termination", time=t + h)

    def cs_calls(self) -> CsCalls | None:
        """The prepared per-step calls (after ``setup``; None before)."""
        return self._calls

    def native_problem(self) -> str | None:
        """The FMI 3 clocks it declares need Event Mode, which the kernel does not do."""
        clocks = [
            key[len(UNSUPPORTED_PREFIX) :]
            for key, value in self.component.interface.facts
            if key.startswith(UNSUPPORTED_PREFIX) and value.startswith("FMI 3 clock")
        ]
        if not clocks:
            return None
        listed = ", ".join(f"`{c}`" for c in clocks)
        return (
            f"declares the FMI 3 clock(s) {listed}, which need Event Mode: the Python path "
            "runs it (without Event Mode, its output clocks ignored)"
        )


class Fmi3ModelExchange(Fmi3Runner):
    """FMI 3 model exchange: integrated between communication points (:mod:`.me`)."""

    advance_function = (
        "the integration (fmi3GetContinuousStateDerivatives/fmi3SetContinuousStates/...)"
    )

    def _new_fmu(self, md: Any, root: Path) -> Any:
        from fmpy.fmi3 import FMU3Model

        return FMU3Model(**self._fmpy_arguments(md.modelExchange, root))

    def _stepper(self, start: float, stop: float) -> Stepper:
        fmu = self._fmu
        calls = VersionCalls(fmu.getContinuousStateDerivatives, fmu.updateDiscreteStates)
        return ModelExchange(
            self, fmu, self._md, start, stop, self.config, calls, self._event_inputs
        ).advance

    def sets_in_event_mode(self, port: Port) -> bool:
        """Discrete inputs and driven parameters: set in Event Mode only (:mod:`.me`)."""
        return discrete_input(port)


#: The runner class per interface type.
RUNNERS: dict[str, type[FmuRunner]] = {"cs": Fmi3CoSimulation, "me": Fmi3ModelExchange}
