"""FMI 2.0 runners: co-simulation and model exchange.

What FMI 2 does its own way: a callback structure (logger, memory functions) handed to
``fmi2Instantiate``; ``fmi2SetupExperiment`` before Initialization Mode; Real, Integer and
Boolean values (Boolean is a C int); ``fmi2DoStep`` with one flag; and, for model exchange,
``fmi2GetDerivatives`` and ``fmi2NewDiscreteStates``.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fmionnx.core.cosim import CsCalls, NativeSteppable
from fmionnx.core.errors import ModelTerminated
from fmionnx.core.runner import terminated
from fmionnx.core.types import Component, DType, Port
from fmionnx.kinds.fmu.me import ModelExchange, VersionCalls, discrete_input
from fmionnx.kinds.fmu.rollback import FmuRollback
from fmionnx.kinds.fmu.runner import (
    FMI_DISCARD,
    FMI_OK,
    FMI_WARNING,
    FmuRunner,
    Stepper,
)
from fmionnx.kinds.fmu.values import ValueFunctions

#: FMI 2 get/set functions: type name and C element type per dtype.
VALUES = ValueFunctions(
    prefix="fmi2",
    types={
        DType.FLOAT64: ("Real", ctypes.c_double),
        DType.INT32: ("Integer", ctypes.c_int),
        DType.BOOL: ("Boolean", ctypes.c_int),
    },
    counts_values=False,
)

#: ``noSetFMUStatePriorToCurrentPoint`` of ``fmi2DoStep``: fmi2True, nothing is ever rolled back.
_NO_ROLLBACK = 1


class Fmi2Runner(FmuRunner):
    """What FMI 2 co-simulation and model exchange share: instantiation and initialization."""

    values = VALUES

    def _instantiate_fmu(self) -> None:
        from fmpy import calloc, free
        from fmpy.fmi2 import (
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.logging import addLoggerProxy

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self._logger)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(ctypes.byref(callbacks))
        self._callbacks = callbacks  # the FMU keeps pointers into it until freeInstance
        fmu = self._fmu
        self._guard("fmi2Instantiate", lambda: fmu.instantiate(callbacks=callbacks))

    def _logger(self, env: Any, name: Any, status: int, category: Any, message: Any) -> None:
        self._log_message(status, message)

    def _initialize(self, start: float, stop: float) -> None:
        fmu = self._fmu
        tolerance = self.config.tolerance
        self._guard(
            "fmi2SetupExperiment",
            lambda: fmu.setupExperiment(tolerance=tolerance, startTime=start, stopTime=stop),
        )
        self._guard("fmi2EnterInitializationMode", fmu.enterInitializationMode)
        self._call_all(self._initial_input_calls(), start)
        self._guard("fmi2ExitInitializationMode", fmu.exitInitializationMode)


class Fmi2CoSimulation(Fmi2Runner, FmuRollback, NativeSteppable):
    """FMI 2 co-simulation: one raw ``fmi2DoStep`` per step.

    Its prepared calls (:meth:`cs_calls`) are what the native kernel steps instead. It
    saves and restores its state for iterated algebraic loops (:mod:`.rollback`).
    """

    state_functions = ("fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate")

    _do_step_function: Callable[..., int]
    advance_function = "fmi2DoStep"
    #: ``fmi2Discard`` with ``fmi2Terminated``: the model asks to end the run.
    discard_may_end = True

    def __init__(self, component: Component, driven: frozenset[str]) -> None:
        super().__init__(component, driven)
        self._calls: CsCalls | None = None

    def _new_fmu(self, md: Any, root: Path) -> Any:
        from fmpy.fmi2 import FMU2Slave

        return FMU2Slave(**self._fmpy_arguments(md.coSimulation, root))

    def _stepper(self, start: float, stop: float) -> Stepper:
        assert self._instance is not None
        self._do_step_function = self._fmu.dll.fmi2DoStep
        self._calls = CsCalls(
            self._instance,
            tuple(self._set_calls),
            self._do_step_function,
            tuple(self._get_calls),
        )
        return self._do_step

    def _do_step(self, t: float, h: float) -> None:
        status = self._do_step_function(self._instance, t, h, _NO_ROLLBACK)
        if status > FMI_WARNING:
            if status == FMI_DISCARD:
                ending = self.termination_requested(t, h)
                if ending is not None:
                    raise ending
            self._check("fmi2DoStep", status, t)

    def termination_requested(self, t: float, h: float) -> ModelTerminated | None:
        """After ``fmi2DoStep`` returned ``fmi2Discard``: does the FMU ask to end the run?

        FMI 2.0 (section 4.2.3): the master then asks ``fmi2GetBooleanStatus(fmi2Terminated)``;
        true means the slave wants to terminate the simulation, which FMPy and the reference
        tools treat as the end of the run, not as a failure. A refused query counts as false
        (a plain discard: the fault it was). The native kernel asks through this too.
        """
        from fmpy.fmi2 import fmi2Terminated

        flag = ctypes.c_int(0)
        query = self._fmu.dll.fmi2GetBooleanStatus
        if query(self._instance, fmi2Terminated, ctypes.byref(flag)) != FMI_OK or not flag.value:
            return None
        return terminated(self.component.name, "the FMU requested termination", time=t + h)

    def cs_calls(self) -> CsCalls | None:
        """The prepared per-step calls (after ``setup``; None before)."""
        return self._calls

    def native_problem(self) -> str | None:
        """None: the native kernel can step it (:class:`fmionnx.core.cosim.NativeSteppable`)."""
        return None


class Fmi2ModelExchange(Fmi2Runner):
    """FMI 2 model exchange: integrated between communication points (:mod:`.me`)."""

    advance_function = "the integration (fmi2GetDerivatives/fmi2SetContinuousStates/...)"

    def _new_fmu(self, md: Any, root: Path) -> Any:
        from fmpy.fmi2 import FMU2Model

        return FMU2Model(**self._fmpy_arguments(md.modelExchange, root))

    def _stepper(self, start: float, stop: float) -> Stepper:
        fmu = self._fmu
        calls = VersionCalls(fmu.getDerivatives, fmu.newDiscreteStates)
        return ModelExchange(
            self, fmu, self._md, start, stop, self.config, calls, self._event_inputs
        ).advance

    def sets_in_event_mode(self, port: Port) -> bool:
        """Discrete inputs and driven parameters: set in Event Mode only (:mod:`.me`)."""
        return discrete_input(port)


#: The runner class per interface type.
RUNNERS: dict[str, type[FmuRunner]] = {"cs": Fmi2CoSimulation, "me": Fmi2ModelExchange}
