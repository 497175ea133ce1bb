"""Model exchange: integrate an FMU between communication points, with event handling.

The integrator is fmpy's CVode binding (``fmpy.sundials.CVodeSolver``, BDF, relative tolerance
from the component's ``tolerance``, else the FMU's default experiment, else 1e-5) or a
fixed-step forward Euler whose step is the component's period. Events follow FMI 2.0 §3.2.2
and FMI 3.0 §3.3: time events (``nextEventTime``), state events (event-indicator roots found by
CVode, sign changes for Euler) and step events (``completedIntegratorStep``) all enter Event
Mode, iterate the discrete states until they settle, and return to Continuous-Time Mode; CVode
is re-initialized at the event time.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from fmionnx.core.runner import fault, terminated
from fmionnx.core.types import Causality, Port

if TYPE_CHECKING:
    from fmionnx.kinds.fmu.kind import FmuConfig
    from fmionnx.kinds.fmu.runner import FmuRunner
    from fmionnx.kinds.fmu.values import ValueGroup

#: The highest FMI status a run goes on after (as :data:`fmionnx.kinds.fmu.runner.FMI_WARNING`).
FMI_WARNING = 1


@dataclass(frozen=True)
class VersionCalls:
    """The model-exchange calls FMI 2 and FMI 3 name differently (fmpy methods of the FMU).

    ``get_derivatives(array, n)``: ``fmi2GetDerivatives`` / ``fmi3GetContinuousStateDerivatives``.
    ``update_discrete_states()``: ``fmi2NewDiscreteStates`` / ``fmi3UpdateDiscreteStates``, both
    as fmpy returns them: (update needed, terminate, nominals changed, values changed, next event
    time defined, next event time).
    """

    get_derivatives: Callable[[Any, int], Any]
    update_discrete_states: Callable[[], tuple[bool, bool, bool, bool, bool, float]]


class _HeldInputs:
    """fmpy's solver re-applies inputs at each root-function call; ours are held constant."""

    def apply(self, time: float, *, continuous: bool = True, discrete: bool = True) -> None:
        """Inputs were set at the communication point and stay constant until the next."""


def discrete_input(port: Port) -> bool:
    """Whether model exchange may set ``port`` only in Event Mode, not in Continuous-Time Mode.

    FMI 2.0 (section 3.2.3) and FMI 3.0 (section 3.2.5) let Continuous-Time Mode set only
    continuous inputs (``variability="continuous"``, floating point); discrete inputs (every
    Integer and Boolean one) and tunable parameters driven by a connection change only at
    events.
    """
    if port.causality is Causality.PARAMETER:
        return True
    return not port.dtype.is_float or port.variability not in (None, "continuous")


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


class ModelExchange:
    """The continuous-time part of one ME FMU instance (created right after initialization)."""

    def __init__(
        self,
        runner: FmuRunner,
        fmu: Any,
        md: Any,
        start: float,
        stop: float,
        config: FmuConfig,
        calls: VersionCalls,
        event_inputs: Sequence[ValueGroup] = (),
    ) -> None:
        self._runner = runner
        self._fmu = fmu
        self._event_inputs = tuple(event_inputs)
        #: The discrete inputs as last set (in Initialization or Event Mode).
        self._applied = [group.array.copy() for group in self._event_inputs]
        self._update_discrete_states = calls.update_discrete_states
        self._nx = int(md.numberOfContinuousStates)
        self._nz = int(md.numberOfEventIndicators)
        self._needs_completed = bool(md.modelExchange.needsCompletedIntegratorStep)
        self._next_event = math.inf
        self._guarded(start, self._event_iteration, start)
        fmu.enterContinuousTimeMode()
        self._solver_name = config.solver
        tolerance = config.tolerance
        if (
            tolerance is None
            and md.defaultExperiment is not None
            and md.defaultExperiment.tolerance
        ):
            tolerance = float(md.defaultExperiment.tolerance)
        self._tolerance = tolerance or 1e-5
        get_dx = calls.get_derivatives
        self._get_x = fmu.getContinuousStates
        self._set_x = fmu.setContinuousStates
        self._get_dx = get_dx
        self._get_z = fmu.getEventIndicators
        self._x = np.zeros(max(self._nx, 1))
        self._dx = np.zeros(max(self._nx, 1))
        self._z = np.zeros(max(self._nz, 1))
        self._z_prev = np.zeros(max(self._nz, 1))
        self._px = self._x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._pdx = self._dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._pz = self._z.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._solver: Any = None
        if self._solver_name == "cvode":
            from fmpy.sundials import CVodeSolver

            self._solver = CVodeSolver(
                nx=self._nx,
                nz=self._nz,
                get_x=self._get_x,
                set_x=self._set_x,
                get_dx=get_dx,
                get_z=self._get_z,
                get_nominals=fmu.getNominalsOfContinuousStates,
                set_time=fmu.setTime,
                input=_HeldInputs(),
                startTime=start,
                maxStep=(stop - start) / 50.0,
                relativeTolerance=self._tolerance,
            )
        elif self._nz:
            self._get_z(self._pz, self._nz)

    def _event_iteration(self, t: float) -> None:
        """Iterate discrete states until they settle (in Event or Initialization Mode)."""
        update = self._update_discrete_states
        needed, terminate = True, False
        defined, next_time = False, 0.0
        while needed and not terminate:
            needed, terminate, _, _, defined, next_time = update()
        if terminate:
            raise terminated(self._runner.component.name, "the FMU requested termination", time=t)
        self._next_event = float(next_time) if defined else math.inf

    def _guarded(self, t: float, function: Any, *args: Any) -> Any:
        from fmpy.fmi1 import FMICallException

        try:
            return function(*args)
        except FMICallException as exc:
            raise self._runner.fault_for(exc.function, exc.status, t) from None
        except RuntimeError as exc:  # CVode failures
            self._runner.faulted = True
            raise fault(self._runner.component.name, str(exc), time=t) from None

    def advance(self, t: float, h: float) -> None:
        """Integrate from ``t`` to ``t + h`` handling every event on the way."""
        self._guarded(t, self._advance, t, t + h)

    def _input_event(self, t: float) -> None:
        """New values of discrete inputs: an event at ``t`` (FMI 2.0 3.2.3, FMI 3.0 3.2.5).

        Continuous-Time Mode forbids setting a discrete input (or a tunable parameter driven
        by a connection): the master enters Event Mode, sets them, iterates the discrete
        states until they settle and returns to Continuous-Time Mode, as FMPy does at an
        input's discontinuity. Unchanged values cause no event.
        """
        changed = [
            (group, applied)
            for group, applied in zip(self._event_inputs, self._applied, strict=True)
            if not np.array_equal(group.array, applied)
        ]
        if not changed:
            return
        fmu = self._fmu
        fmu.enterEventMode()
        for group, applied in changed:
            function, args, name = group.call
            status = int(function(*args))
            if status > FMI_WARNING:
                raise self._runner.fault_for(name, status, t)
            applied[:] = group.array
        self._event_iteration(t)
        fmu.enterContinuousTimeMode()
        if self._solver is not None:
            self._solver.reset(t)
        elif self._nz:
            self._get_z(self._pz, self._nz)

    def _advance(self, t: float, t_end: float) -> None:
        fmu = self._fmu
        if self._event_inputs:
            self._input_event(t)
        time = t
        while time < t_end and not _close(time, t_end):
            target = t_end
            if self._next_event < target and not _close(self._next_event, target):
                target = self._next_event
            if self._solver is not None:
                state_event, _roots, time = self._solver.step(time, target)
                state_event = bool(state_event)
            else:
                state_event = self._euler(time, target)
                time = target
            if _close(time, t_end):
                time = t_end  # communication points are exact, never accumulated
            fmu.setTime(time)
            step_event = terminate = False
            if self._needs_completed:
                step_event, terminate = fmu.completedIntegratorStep()
            if terminate:
                raise terminated(
                    self._runner.component.name, "the FMU requested termination", time=time
                )
            time_event = _close(time, self._next_event)
            if state_event or step_event or time_event:
                fmu.enterEventMode()
                self._event_iteration(time)
                fmu.enterContinuousTimeMode()
                if self._solver is not None:
                    self._solver.reset(time)
                elif self._nz:
                    self._get_z(self._pz, self._nz)

    def _euler(self, t: float, t_next: float) -> bool:
        """One forward-Euler step; True when an event indicator changed sign."""
        nx, nz = self._nx, self._nz
        if nx:
            self._get_x(self._px, nx)
            self._get_dx(self._pdx, nx)
            self._x[:nx] += (t_next - t) * self._dx[:nx]
        self._fmu.setTime(t_next)
        if nx:
            self._set_x(self._px, nx)
        if not nz:
            return False
        self._z_prev[:] = self._z
        self._get_z(self._pz, nz)
        return bool(np.any((self._z_prev[:nz] > 0) != (self._z[:nz] > 0)))
