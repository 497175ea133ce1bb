"""A co-simulation step as C calls: the contract between a kind's runners and the native kernel.

The runtime's native kernel (:mod:`fmionnx.runtime.native`) steps runs of co-simulation
models with one C call per communication point: it makes, with the same arrays, exactly the
calls a runner would make (set the inputs, step, get the outputs). It never imports a kind:
a runner offers itself by deriving from :class:`NativeSteppable`, as the FMU kind's
co-simulation runners do (FMI 2 and FMI 3), and says through :class:`NativeCandidate` why it cannot
be stepped so when it cannot.
"""

from __future__ import annotations

import ctypes
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

from fmionnx.core.errors import ModelTerminated, RunError

#: One prepared C call: the function, its arguments, its name (for fault messages).
RawCall = tuple[Callable[..., int], tuple[object, ...], str]

#: Status values (FMI 2 and 3 share the numbering).
STATUS_OK = 0
#: The highest status a run goes on after.
STATUS_WARNING = 1
#: ``fmi2DoStep``'s "only part of the step was computed": with ``fmi2Terminated``, the end.
STATUS_DISCARD = 2


@dataclass(frozen=True)
class CsCalls:
    """What a co-simulation runner calls per step: set, doStep, get.

    The native kernel makes the same calls with the same arrays. ``step_flags`` (FMI 3 only)
    are the output arguments ``fmi3DoStep`` writes (``eventHandlingNeeded``,
    ``terminateSimulation``, ``earlyReturn``, ``lastSuccessfulTime``): the kernel passes these
    very objects, so the runner reads what the model wrote whichever path stepped it.
    """

    instance: ctypes.c_void_p
    set_calls: tuple[RawCall, ...]
    do_step: Callable[..., int]
    get_calls: tuple[RawCall, ...]
    step_flags: tuple[ctypes.c_bool, ctypes.c_bool, ctypes.c_bool, ctypes.c_double] | None = None


class NativeCandidate(ABC):
    """A runner that can say why the native kernel cannot step it.

    Nominal, not a protocol: a runner is stepped natively only if its class says so. A wrapper
    that hands attribute lookups on to the runner inside (a test's probe, a proxy) is not the
    runner, and its own step must stay the one that is called.
    """

    @abstractmethod
    def native_problem(self) -> str | None:
        """Why this runner's steps must stay in Python, or None when the kernel can take them."""


class NativeSteppable(NativeCandidate):
    """A runner the native kernel can step (once :meth:`native_problem` says None)."""

    #: The name of the function that advances it (``fmi2DoStep``), for fault messages.
    advance_function: ClassVar[str]
    #: Whether a ``Discard`` from the step may be the model asking to end the run (FMI 2's
    #: ``fmi2Terminated``, asked through :meth:`termination_requested`).
    discard_may_end: ClassVar[bool]

    @abstractmethod
    def cs_calls(self) -> CsCalls | None:
        """The calls of one step (None before ``setup``)."""

    @abstractmethod
    def fault_for(self, function: str, status: int, t: float) -> RunError:
        """The fault a status above Warning from ``function`` at ``t`` is, named as the
        runner names its own."""

    @abstractmethod
    def termination_requested(self, t: float, h: float) -> ModelTerminated | None:
        """The model's request to end the run after the step from ``t``, if it made one."""
