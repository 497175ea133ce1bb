"""FMU runner: FMI 2.0 and 3.0, co-simulation and model exchange.

fmpy's low-level classes (``FMU2Slave``, ``FMU2Model``, ``FMU3Slave``, ``FMU3Model``) load the
library and perform the one-time calls (instantiate, initialization). Per step, the raw FMI C
functions are called directly with value-reference arrays and value buffers prepared once
(:mod:`.fmu_values`). Any status above ``Warning`` stops the run with a RunError naming the
component, the FMI function and the simulated time, plus the FMU's last log messages.
"""

from __future__ import annotations

import ctypes
import shutil
import tempfile
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fmionnx.core.archive import safe_extract
from fmionnx.core.errors import RunError
from fmionnx.core.runner import Buffer, fault
from fmionnx.core.types import Causality, Component, DType
from fmionnx.kinds.fmu.description import component_description
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION
from fmionnx.kinds.fmu.kind import FmuConfig
from fmionnx.kinds.fmu.values import (
    RawCall,
    ValueGroup,
    build_groups,
    port_element_count,
    set_scalars,
)

_STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")
_FMI_WARNING = 1


@dataclass(frozen=True)
class Fmi2CsCalls:
    """What :meth:`FmuRunner.step` calls for FMI 2 co-simulation: set, doStep, get."""

    instance: ctypes.c_void_p
    set_calls: tuple[RawCall, ...]
    do_step: Callable[..., int]
    get_calls: tuple[RawCall, ...]


def status_label(status: int) -> str:
    """``Error`` for 3 and so on (FMI 2 and 3 share the numbering)."""
    return _STATUS[status] if 0 <= status < len(_STATUS) else f"illegal status {status}"


class FmuRunner:
    """Runs one FMU instance; chooses CS or ME from the spec (default: CS when offered)."""

    def __init__(self, component: Component, driven: frozenset[str]) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        self._driven = driven
        self._log: deque[str] = deque(maxlen=8)
        self._tmp: Path | None = None
        self._fmu: Any = None
        self._instance: ctypes.c_void_p | None = None
        self._inputs: list[ValueGroup] = []
        self._outputs: list[ValueGroup] = []
        self._set_calls: list[RawCall] = []
        self._get_calls: list[RawCall] = []
        self._callbacks: Any = None
        self._me: Any = None
        self._terminated = False
        self._time = 0.0
        assert isinstance(component.config, FmuConfig)
        self.config = component.config
        self.interface_type: str = component.config.interface
        self.fmi3 = (component.interface.fact("fmiVersion") or "2.0").startswith("3")

    # -- life cycle ---------------------------------------------------------------------------

    def instantiate(self) -> None:
        """Unpack the FMU safely, load its library and create the instance."""
        path = self.component.path
        if path.is_dir():
            root = path
        else:
            self._tmp = Path(tempfile.mkdtemp(prefix=f"fmionnx-{self.component.name}-"))
            root = safe_extract(path, self._tmp)
        md = component_description(self.component, (root / MODEL_DESCRIPTION).read_bytes)
        self._md = md
        if self.fmi3:
            self._instantiate_fmi3(md, root)
        else:
            self._instantiate_fmi2(md, root)
        self._instance = ctypes.c_void_p(self._fmu.component)

    def _logger_fmi2(self, env: Any, name: Any, status: int, category: Any, message: Any) -> None:
        text = message.decode("utf-8", "replace") if message else ""
        self._log.append(f"[{status_label(status)}] {text}")

    def _logger_fmi3(self, env: Any, status: int, category: Any, message: Any) -> None:
        text = message.decode("utf-8", "replace") if message else ""
        self._log.append(f"[{status_label(status)}] {text}")

    def _instantiate_fmi2(self, md: Any, root: Path) -> None:
        from fmpy import calloc, free
        from fmpy.fmi2 import (
            FMU2Model,
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.logging import addLoggerProxy

        me = self.interface_type == "me"
        kind = md.modelExchange if me else md.coSimulation
        cls = FMU2Model if me else FMU2Slave
        self._fmu = cls(
            guid=md.guid,
            unzipDirectory=str(root),
            modelIdentifier=kind.modelIdentifier,
            instanceName=self.component.name,
        )
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self._logger_fmi2)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(ctypes.byref(callbacks))
        self._callbacks = callbacks
        self._guard("fmi2Instantiate", lambda: self._fmu.instantiate(callbacks=callbacks))

    def _instantiate_fmi3(self, md: Any, root: Path) -> None:
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        me = self.interface_type == "me"
        kind = md.modelExchange if me else md.coSimulation
        cls = FMU3Model if me else FMU3Slave
        self._fmu = cls(
            guid=md.guid,
            unzipDirectory=str(root),
            modelIdentifier=kind.modelIdentifier,
            instanceName=self.component.name,
        )
        self._guard("fmi3Instantiate", lambda: self._fmu.instantiate(logMessage=self._logger_fmi3))

    def setup(self, start: float, stop: float) -> None:
        """Parameters and start values, then initialization mode per FMI 2 / FMI 3."""
        self._time = start
        component = self.component
        dll = self._fmu.dll
        inst = self._instance
        assert inst is not None
        interface = component.interface
        in_ports = [
            p
            for p in interface.ports
            if p.causality is Causality.INPUT
            or (p.causality is Causality.PARAMETER and p.name in self._driven)
        ]
        out_ports = list(interface.with_causality(Causality.OUTPUT))
        self._inputs = build_groups(dll, inst, in_ports, fmi3=self.fmi3, setter=True)
        self._outputs = build_groups(dll, inst, out_ports, fmi3=self.fmi3, setter=False)
        self._set_calls = [g.call for g in self._inputs]
        self._get_calls = [g.call for g in self._outputs]
        explicit = {p.port: p.value for p in component.parameters}
        for group in self._inputs:
            for name, view in group.views.items():
                port = component.port(name)
                value = explicit.get(name, port.start)
                if value is not None and port.dtype is not DType.STRING:
                    view[:] = np.asarray(value, dtype=view.dtype).reshape(-1)[: view.size]
        for parameter in component.parameters:
            port = component.port(parameter.port)
            function, status = set_scalars(dll, inst, port, parameter.value, fmi3=self.fmi3)
            self._check(function, status, start, port=parameter.port)
        tolerance = self.config.tolerance
        fmu = self._fmu
        if self.fmi3:
            self._guard(
                "fmi3EnterInitializationMode",
                lambda: fmu.enterInitializationMode(
                    tolerance=tolerance, startTime=start, stopTime=stop
                ),
            )
            self._call_all(self._set_calls, start)
            self._guard("fmi3ExitInitializationMode", fmu.exitInitializationMode)
        else:
            self._guard(
                "fmi2SetupExperiment",
                lambda: fmu.setupExperiment(tolerance=tolerance, startTime=start, stopTime=stop),
            )
            self._guard("fmi2EnterInitializationMode", fmu.enterInitializationMode)
            self._call_all(self._set_calls, start)
            self._guard("fmi2ExitInitializationMode", fmu.exitInitializationMode)
        if self.interface_type == "me":
            from fmionnx.kinds.fmu.me import ModelExchange

            self._me = ModelExchange(self, fmu, self._md, start, stop, self.config)
        else:
            self._prepare_do_step()
        self._call_all(self._get_calls, start)

    def _prepare_do_step(self) -> None:
        dll = self._fmu.dll
        if self.fmi3:
            self._flags = [ctypes.c_bool() for _ in range(3)]
            self._last_time = ctypes.c_double()
            self._do_step = dll.fmi3DoStep
            self._do_step_tail: tuple[object, ...] = (
                True,
                *(ctypes.byref(f) for f in self._flags),
                ctypes.byref(self._last_time),
            )
        else:
            self._do_step = dll.fmi2DoStep
            self._do_step_tail = (1,)

    # -- buffers --------------------------------------------------------------------------------

    def input_buffer(self, port: str) -> Buffer:
        """Flat view of the input's slot in its type group."""
        for group in self._inputs:
            if port in group.views:
                return group.views[port]
        msg = f"{self.component.name}.{port} is not a runtime input of this FMU"
        raise KeyError(msg)

    def output_buffer(self, port: str) -> Buffer:
        """Flat view of the output's slot in its type group."""
        for group in self._outputs:
            if port in group.views:
                return group.views[port]
        msg = f"{self.component.name}.{port} is not a numeric output of this FMU"
        raise KeyError(msg)

    def fmi2_cs_calls(self) -> Fmi2CsCalls | None:
        """The prepared per-step calls of an FMI 2 co-simulation instance (after ``setup``).

        A native stepper (:mod:`fmionnx.runtime.native`) makes the same calls with
        the same arrays; None for model exchange, FMI 3, or before setup.
        """
        if self.fmi3 or self._me is not None or self._instance is None:
            return None
        if self.interface_type != "cs" or getattr(self, "_do_step", None) is None:
            return None
        return Fmi2CsCalls(
            self._instance, tuple(self._set_calls), self._do_step, tuple(self._get_calls)
        )

    # -- stepping -------------------------------------------------------------------------------

    def step(self, t: float, h: float) -> None:
        """Set inputs, advance by ``h`` (doStep, or integrate for ME), get outputs."""
        for function, args, name in self._set_calls:
            status = function(*args)
            if status > _FMI_WARNING:
                self._check(name, status, t)
        if self._me is not None:
            self._me.advance(t, t + h)
        else:
            status = self._do_step(self._instance, t, h, *self._do_step_tail)
            if status > _FMI_WARNING:
                self._check("fmi3DoStep" if self.fmi3 else "fmi2DoStep", status, t)
            if self.fmi3 and self._flags[1].value:
                raise fault(self.component.name, "the FMU requested termination", time=t + h)
        for function, args, name in self._get_calls:
            status = function(*args)
            if status > _FMI_WARNING:
                self._check(name, status, t + h)

    def produce(self, port: str) -> None:
        """FMU outputs are refreshed every step; nothing is lazy."""

    def terminate(self) -> None:
        """Terminate (when initialized and not faulted) and free the instance and library."""
        if self._terminated:
            return
        self._terminated = True
        fmu = self._fmu
        try:
            if fmu is not None and fmu.component:
                try:
                    fmu.terminate()
                except Exception:
                    self._log.append("terminate refused")
                fmu.freeInstance()
        finally:
            self._me = None
            if self._tmp is not None:
                shutil.rmtree(self._tmp, ignore_errors=True)

    # -- errors ---------------------------------------------------------------------------------

    def _call_all(self, calls: list[RawCall], t: float) -> None:
        for function, args, name in calls:
            self._check(name, int(function(*args)), t)

    def _check(self, function: str, status: int, t: float, *, port: str | None = None) -> None:
        if status <= _FMI_WARNING:
            return
        raise self.fault_for(function, status, t, port=port)

    def fault_for(self, function: str, status: int, t: float, *, port: str | None = None) -> RunError:
        """RunError for an FMI call that returned ``status``, with the last log lines."""
        message = f"{function} returned {status_label(status)}"
        if self._log:
            message += " (FMU log: " + " | ".join(self._log) + ")"
        return fault(self.component.name, message, time=t, port=port)

    def _guard(self, function: str, call: Any) -> None:
        from fmpy.fmi1 import FMICallException

        try:
            call()
        except FMICallException as exc:
            raise self.fault_for(exc.function, exc.status, self._time) from None
        except Exception as exc:
            raise fault(self.component.name, f"{function} failed: {exc}", time=self._time) from None


def element_count(component: Component, port: str) -> int:
    """Values of one port (for callers sizing buffers)."""
    return port_element_count(component.port(port))
