"""FMU runners: what FMI 2.0 and 3.0, co-simulation and model exchange have in common.

As in fmpy's ``fmi2``/``fmi3`` modules there is one class per FMI version and interface type:
``Fmi2CoSimulation`` and ``Fmi2ModelExchange`` (:mod:`.fmi2`), ``Fmi3CoSimulation`` and
``Fmi3ModelExchange`` (:mod:`.fmi3`); :func:`make_fmu_runner` picks one from the compiled
interface's ``fmiVersion`` and the resolved interface type. Their base :class:`FmuRunner`
holds what depends on neither: unpacking, the shared model description (:mod:`.description`),
value buffers, parameters and start values, the per-step set/get, status checks and fault
messages, terminate and clean-up.

fmpy's low-level classes (``FMU2Slave``, ``FMU2Model``, ``FMU3Slave``, ``FMU3Model``) load the
library and perform the one-time calls (instantiate, initialization). Per step, the raw FMI C
functions are called directly with value-reference arrays and value buffers prepared once
(:mod:`.values`). Any status above ``Warning`` stops the run with a RunError naming the
component, the FMI function and the simulated time, plus the FMU's last log messages.
"""

from __future__ import annotations

import ctypes
from abc import abstractmethod
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from fmionnx.core.archive import safe_extract
from fmionnx.core.cosim import STATUS_DISCARD, STATUS_OK, STATUS_WARNING, NativeCandidate, RawCall
from fmionnx.core.errors import ModelError, ModelTerminated, RunError
from fmionnx.core.runner import Buffer, fault
from fmionnx.core.scratch import make_scratch, remove_scratch
from fmionnx.core.types import Causality, Component, DType, Port
from fmionnx.kinds.fmu.aliases import settable_inputs
from fmionnx.kinds.fmu.description import component_description
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION, contained_library
from fmionnx.kinds.fmu.kind import FmuConfig
from fmionnx.kinds.fmu.libraries import (
    LibraryKey,
    LoadedFmu,
    active_pool,
    library_key,
    shareable,
)
from fmionnx.kinds.fmu.loading import load_library
from fmionnx.kinds.fmu.values import (
    ValueFunctions,
    ValueGroup,
    build_groups,
    port_element_count,
    set_scalars,
)

_STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")

#: Characters of one FMU log message kept for fault messages (a model may log megabytes).
LOG_MESSAGE_CHARS = 300

#: Characters of the FMU's log a fault message quotes (the newest ones).
LOG_CHARS = 600

#: FMI status values (FMI 2 and 3 share the numbering; :mod:`fmionnx.core.cosim`).
FMI_OK = STATUS_OK
#: The highest status a run goes on after.
FMI_WARNING = STATUS_WARNING
#: ``fmi2DoStep``'s "only part of the step was computed": with ``fmi2Terminated``, the end.
FMI_DISCARD = STATUS_DISCARD

#: Advances an initialized instance from communication point ``t`` by ``h``.
Stepper = Callable[[float, float], None]


def status_label(status: int) -> str:
    """``Error`` for 3 and so on (FMI 2 and 3 share the numbering)."""
    return _STATUS[status] if 0 <= status < len(_STATUS) else f"illegal status {status}"


def _not_set_up(t: float, h: float) -> None:
    """The stepper before ``setup`` and after ``terminate``: stepping then is a caller's bug."""
    msg = f"an FMU runner was stepped at t={t:g} s before setup() or after terminate()"
    raise RuntimeError(msg)


class FmuRunner(NativeCandidate):
    """Runs one FMU instance; subclasses add what their FMI version and interface type need.

    The hooks, in the order they are called: ``_new_fmu`` (the fmpy object of the interface
    type), ``_instantiate_fmu`` (the version's instantiate call), ``_initialize`` (the
    version's initialization around the first set of inputs) and ``_stepper`` (what advances
    the instance per step: doStep, or integration for model exchange).
    """

    #: The FMI version's get/set function names and value types.
    values: ClassVar[ValueFunctions]

    #: What advancing one step calls, as fault messages name it (``fmi2DoStep`` ...).
    advance_function: ClassVar[str]

    def native_problem(self) -> str | None:
        """Why the native kernel cannot step this runner (:mod:`fmionnx.core.cosim`): a
        model-exchange FMU is integrated in Python; co-simulation runners override this."""
        return "a model-exchange FMU (integrated in Python between communication points)"

    def __init__(self, component: Component, driven: frozenset[str]) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        self._driven = driven
        self._log: deque[str] = deque(maxlen=8)
        self._tmp: Path | None = None
        self._md: Any = None
        self._fmu: Any = None
        self._instance: ctypes.c_void_p | None = None
        self._inputs: list[ValueGroup] = []
        #: Input ports not set because another port of the same value references is (aliases),
        #: with that port.
        self._stand_in: dict[str, str] = {}
        self._outputs: list[ValueGroup] = []
        self._event_inputs: list[ValueGroup] = []
        self._set_calls: list[RawCall] = []
        self._get_calls: list[RawCall] = []
        self._advance: Stepper = _not_set_up
        #: A termination request of the last advance, raised once its outputs are got.
        self._ending: ModelTerminated | None = None
        self._terminated = False
        #: Whether a call of this instance failed (then its library is not kept: :mod:`.libraries`).
        self.faulted = False
        #: The pool key of this FMU in a process that keeps libraries.
        self._library_key: LibraryKey | None = None
        self._time = 0.0
        assert isinstance(component.config, FmuConfig)
        self.config = component.config

    # -- life cycle ---------------------------------------------------------------------------

    def instantiate(self) -> None:
        """Unpack the FMU safely, load its library and create the instance.

        In a process that keeps libraries (:mod:`.libraries`) the unpacked, loaded FMU of an
        earlier clean run of the same file is taken instead, when there is one.
        """
        pool = active_pool()
        if pool is not None:
            self._library_key = library_key(self.component.path, type(self))
        loaded = pool.take(self._library_key) if pool and self._library_key else None
        if loaded is not None:
            self._tmp, self._md, self._fmu = loaded.scratch, loaded.md, loaded.fmu
            self._fmu.instanceName = self.component.name
        else:
            self._load()
        self._instantiate_fmu()
        self._instance = ctypes.c_void_p(self._fmu.component)

    def _load(self) -> None:
        path = self.component.path
        if path.is_dir():
            root = path.absolute()  # fmpy changes the working folder before it loads the library
        else:
            self._tmp = make_scratch(self.component.name)
            try:
                root = safe_extract(path, self._tmp)
            except ModelError as exc:  # damaged since it was compiled (or only in its binary)
                raise fault(self.component.name, str(exc), time=0.0) from None
        self._md = component_description(self.component, (root / MODEL_DESCRIPTION).read_bytes)
        md = self._md
        self._fmu = load_library(self.component.name, root, lambda: self._new_fmu(md, root))

    def setup(self, start: float, stop: float) -> None:
        """Parameters and start values, then the version's initialization, then the stepper."""
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
        given = self._driven | {p.port for p in component.parameters}
        try:
            in_ports, self._stand_in = settable_inputs(in_ports, given)
        except RunError as exc:
            raise RunError(
                f"component `{component.name}`: {exc}", component=component.name
            ) from None
        held = [p for p in in_ports if self.sets_in_event_mode(p)]
        steady = [p for p in in_ports if not self.sets_in_event_mode(p)]
        continuous = build_groups(dll, inst, steady, self.values, setter=True)
        #: Inputs that may change only at events (set by the version's event handling).
        self._event_inputs = build_groups(dll, inst, held, self.values, setter=True)
        self._inputs = [*continuous, *self._event_inputs]
        self._outputs = build_groups(dll, inst, out_ports, self.values, setter=False)
        self._set_calls = [g.call for g in continuous]
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
            try:
                function, status = set_scalars(dll, inst, port, parameter.value, self.values)
            except ValueError as exc:  # a binary value that is no hexadecimal text
                raise fault(component.name, str(exc), time=start, port=parameter.port) from None
            self._check(function, status, start, port=parameter.port)
        self._initialize(start, stop)
        self._advance = self._stepper(start, stop)
        self._call_all(self._get_calls, start)

    def sets_in_event_mode(self, port: Port) -> bool:
        """Whether ``port`` is set only in Event Mode, not with every step's inputs.

        Co-simulation sets every input before each step (Step Mode allows it). Model
        exchange overrides this for discrete inputs, which Continuous-Time Mode forbids.
        """
        return False

    @abstractmethod
    def _new_fmu(self, md: Any, root: Path) -> Any:
        """fmpy's object for this version and interface type (loads the library)."""

    @abstractmethod
    def _instantiate_fmu(self) -> None:
        """Create the instance with the version's callbacks (``self._fmu.component``)."""

    @abstractmethod
    def _initialize(self, start: float, stop: float) -> None:
        """Initialization Mode as the version defines it; inputs are set inside it."""

    @abstractmethod
    def _stepper(self, start: float, stop: float) -> Stepper:
        """Prepare stepping right after initialization; return what :meth:`step` calls."""

    def _initial_input_calls(self) -> list[RawCall]:
        """Every input's set call, the event-mode ones included (Initialization Mode)."""
        return [g.call for g in self._inputs]

    def _fmpy_arguments(self, interface: Any, root: Path) -> dict[str, str]:
        """Keyword arguments of fmpy's FMU classes; ``interface`` is ``md.coSimulation`` ...

        The library fmpy will load is checked to lie inside ``root`` first (E017).
        """
        contained_library(root, interface.modelIdentifier)
        return {
            "guid": self._md.guid,
            "unzipDirectory": str(root),
            "modelIdentifier": interface.modelIdentifier,
            "instanceName": self.component.name,
        }

    def _log_message(self, status: int, message: bytes | None) -> None:
        """Keep a log message of the FMU for fault messages (the loggers' common part)."""
        text = message.decode("utf-8", "replace") if message else ""
        if len(text) > LOG_MESSAGE_CHARS:
            text = (
                f"{text[:LOG_MESSAGE_CHARS]}... ({len(text) - LOG_MESSAGE_CHARS} more characters)"
            )
        self._log.append(f"[{status_label(status)}] {text}")

    # -- buffers --------------------------------------------------------------------------------

    def input_buffer(self, port: str) -> Buffer:
        """Flat view of the input's slot in its type group.

        An input alias left unset (:mod:`.aliases`) has none: sharing the variable's slot would
        let whoever copies every input buffer (the isolated child) write the alias's stale
        value over the variable's.
        """
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

    # -- stepping -------------------------------------------------------------------------------

    def step(self, t: float, h: float) -> None:
        """Set inputs, advance by ``h`` (doStep, or integrate for ME), get outputs.

        A model that asks to end the simulation completed its step: its outputs are got
        first, then :class:`ModelTerminated` is raised.
        """
        self._set_inputs(t, h)
        self._advance_step(t, h)
        self._get_outputs(t, h)

    def _advance_step(self, t: float, h: float) -> None:
        try:
            self._advance(t, h)
        except ModelTerminated as exc:
            self._ending = exc

    def _set_inputs(self, t: float, h: float) -> None:
        for function, args, name in self._set_calls:
            status = function(*args)
            if status > FMI_WARNING:
                self._check(name, status, t)

    def _get_outputs(self, t: float, h: float) -> None:
        for function, args, name in self._get_calls:
            status = function(*args)
            if status > FMI_WARNING:
                self._check(name, status, t + h)
        if self._ending is not None:
            ending, self._ending = self._ending, None
            raise ending

    def step_phases(self) -> tuple[tuple[str, Stepper], ...]:
        """:meth:`step` in its three parts, each labelled with the FMI functions it calls.

        An isolated FMU's child process steps through these so that, when the model crashes
        or hangs, the supervisor can name the FMI function it was in
        (:mod:`fmionnx.runtime.isolated`). Together they do exactly what :meth:`step` does.
        """
        setters = "/".join(dict.fromkeys(name for _, _, name in self._set_calls))
        getters = "/".join(dict.fromkeys(name for _, _, name in self._get_calls))
        return (
            (setters or "setting inputs", self._set_inputs),
            (self.advance_function, self._advance_step),
            (getters or "getting outputs", self._get_outputs),
        )

    def produce(self, port: str) -> None:
        """FMU outputs are refreshed every step; nothing is lazy."""

    def terminate(self) -> None:
        """Terminate (when initialized and not faulted) and free the instance and library.

        In a process that keeps libraries, an FMU that ended cleanly and allows several
        instances per process keeps its library loaded and its folder for the next run.
        """
        if self._terminated:
            return
        self._terminated = True
        fmu = self._fmu
        kept = False
        try:
            if fmu is not None and fmu.component:
                try:
                    fmu.terminate()
                except Exception:
                    self._log.append("terminate refused")
                    self.faulted = True
                kept = self._keep_library(fmu)
                if not kept:
                    fmu.freeInstance()
        finally:
            self._advance = _not_set_up  # drops the stepper (a model-exchange integrator ...)
            if self._tmp is not None and not kept:
                remove_scratch(self._tmp)

    def _keep_library(self, fmu: Any) -> bool:
        """Free only the instance and hand the loaded FMU to this process's pool, when it
        keeps libraries and this one may be shared; False (nothing done) otherwise."""
        pool = active_pool()
        key = self._library_key
        if pool is None or key is None or self.faulted or not shareable(self._interface_md()):
            return False
        getattr(fmu, f"{self.values.prefix}FreeInstance")(fmu.component)
        fmu.component = None
        pool.give(LoadedFmu(key, self._md, fmu, self._tmp))
        return True

    def _interface_md(self) -> Any:
        """The model description's element of the interface type in use."""
        md = self._md
        return md.coSimulation if self.config.interface == "cs" else md.modelExchange

    # -- errors ---------------------------------------------------------------------------------

    def _call_all(self, calls: list[RawCall], t: float) -> None:
        for function, args, name in calls:
            self._check(name, int(function(*args)), t)

    def _check(self, function: str, status: int, t: float, *, port: str | None = None) -> None:
        if status <= FMI_WARNING:
            return
        raise self.fault_for(function, status, t, port=port)

    def fault_for(
        self, function: str, status: int, t: float, *, port: str | None = None
    ) -> RunError:
        """RunError for an FMI call that returned ``status``, with the last log lines."""
        self.faulted = True
        message = f"{function} returned {status_label(status)}"
        if self._log:
            log = " | ".join(self._log)
            if len(log) > LOG_CHARS:
                log = "..." + log[-LOG_CHARS:]
            message += f" (FMU log: {log})"
        return fault(self.component.name, message, time=t, port=port)

    def _guard(self, function: str, call: Any) -> None:
        from fmpy.fmi1 import FMICallException

        try:
            call()
        except FMICallException as exc:
            raise self.fault_for(exc.function, exc.status, self._time) from None
        except Exception as exc:
            self.faulted = True
            raise fault(self.component.name, f"{function} failed: {exc}", time=self._time) from None


def make_fmu_runner(component: Component, driven: frozenset[str]) -> FmuRunner:
    """The runner of ``component``'s FMI version and resolved interface type (``cs``/``me``)."""
    from fmionnx.kinds.fmu import fmi2, fmi3

    assert isinstance(component.config, FmuConfig)
    version = component.interface.fact("fmiVersion") or "2.0"
    runners = fmi3.RUNNERS if version.startswith("3") else fmi2.RUNNERS
    return runners[component.config.interface](component, driven)


def element_count(component: Component, port: str) -> int:
    """Values of one port (for callers sizing buffers)."""
    return port_element_count(component.port(port))
