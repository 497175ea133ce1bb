"""One native group: consecutive FMI 2 / FMI 3 co-simulation FMUs stepped by one C call.

The group owns the C structures describing its members (instance, FMI function pointers,
the runner's get/set calls with their value-reference and value arrays, incoming connections
as pointer ranges with their element types). Its :meth:`NativeGroup.step` replaces the
members' Python work at one communication point — transfers, set, doStep, get — and then
samples the members' recorder tracks, which is equivalent to sampling them between the
members' steps: during a group step each member's input buffers are written only by its own
transfers and its output buffers only by its own gets. On a fault, the tracks are sampled
exactly as far as the Python path would have got, and the RunError is the one the Python path
raises (same function, status, time, FMU log); a member that asks to end the run (FMI 2
``fmi2Discard`` with ``fmi2Terminated``, FMI 3 ``terminateSimulation``) ends it as in Python
(ModelTerminated), after its outputs are got.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fmionnx.compile.ir import Connection
from fmionnx.core.cosim import (
    STATUS_DISCARD,
    STATUS_WARNING,
    CsCalls,
    NativeSteppable,
    RawCall,
)
from fmionnx.core.errors import ModelTerminated, RunError
from fmionnx.core.runner import Buffer
from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.transfer import nonfinite_error

#: The runners a group steps.
CsRunner = NativeSteppable


@dataclass(frozen=True)
class MemberPlan:
    """Everything one member contributes: its runner, calls, connections and their views."""

    name: str
    runner: CsRunner
    calls: CsCalls
    connections: tuple[Connection, ...]
    views: tuple[tuple[Buffer, Buffer], ...]
    tracks: tuple[Track | None, Track | None]


def type_code(dtype: np.dtype[np.generic]) -> int | None:
    """The kernel's ``FX_*`` code of a buffer's element type; None when it has none."""
    if not dtype.isnative:
        return None
    return k.TYPE_CODES.get(dtype.name)


def call_type(call: RawCall) -> int | None:
    """The ``FX_*`` code of a prepared get/set call's value array; None if unknown."""
    values = call[1][3]
    if not isinstance(values, ctypes.Array):
        return None
    return type_code(np.dtype(values._type_))


def _address(obj: object) -> int | None:
    """The C address of a ctypes function pointer."""
    return ctypes.cast(obj, ctypes.c_void_p).value  # type: ignore[arg-type]


def _fill_call(spec: k.CallSpec, call: RawCall, *, setter: bool) -> None:
    """``spec`` := the runner's call ``(function, (instance, vrs, nvr, values[, n]), name)``."""
    function, args, name = call
    vrs, values = args[1], args[3]
    code = call_type(call)
    if not isinstance(vrs, ctypes.Array) or not isinstance(values, ctypes.Array) or code is None:
        msg = f"unexpected arguments of {name}"
        raise TypeError(msg)
    spec.function = _address(function)
    spec.vrs = ctypes.addressof(vrs)
    spec.n_vrs = len(vrs)
    spec.values = ctypes.addressof(values)
    spec.n_values = int(args[4]) if len(args) > 4 else len(values)  # type: ignore[call-overload]
    spec.type = code
    spec.setter = int(setter)


def _fill_transfer(spec: k.TransferSpec, connection: Connection, src: Buffer, dst: Buffer) -> None:
    src_type, dst_type = type_code(src.dtype), type_code(dst.dtype)
    if src_type is None or dst_type is None:
        msg = f"{connection}: no kernel element type for {src.dtype} -> {dst.dtype}"
        raise TypeError(msg)
    spec.src = src.ctypes.data
    spec.dst = dst.ctypes.data
    spec.count = int(src.size)
    spec.factor = connection.factor
    spec.offset = connection.offset
    spec.identity = int(connection.factor == 1.0 and connection.offset == 0.0)
    spec.src_type = src_type
    spec.dst_type = dst_type


class NativeGroup:
    """Members of one period, in execution order, stepped by ``fx_group_step``."""

    def __init__(self, kernel: k.Kernel, members: Sequence[MemberPlan], period_steps: int) -> None:
        self.names = tuple(m.name for m in members)
        self.period_steps = period_steps
        self._members = tuple(members)
        transfers = [(c, v) for m in members for c, v in zip(m.connections, m.views, strict=True)]
        self._transfer_array = (k.TransferSpec * max(1, len(transfers)))()
        for i, (connection, (src, dst)) in enumerate(transfers):
            _fill_transfer(self._transfer_array[i], connection, src, dst)
        calls = [
            (call, setter)
            for m in members
            for setter, group in ((True, m.calls.set_calls), (False, m.calls.get_calls))
            for call in group
        ]
        self._call_array = (k.CallSpec * max(1, len(calls)))()
        for i, (call, setter) in enumerate(calls):
            _fill_call(self._call_array[i], call, setter=setter)
        self._member_array = (k.Member * len(members))()
        first_transfer = first_call = 0
        for i, plan in enumerate(members):
            member = self._member_array[i]
            member.instance = plan.calls.instance.value
            member.do_step = _address(plan.calls.do_step)
            flags = plan.calls.step_flags
            if flags is not None:
                member.fmi3 = 1
                member.event_handling_needed = ctypes.addressof(flags[0])
                member.terminate_simulation = ctypes.addressof(flags[1])
                member.early_return = ctypes.addressof(flags[2])
                member.last_successful_time = ctypes.addressof(flags[3])
            member.first_set, member.n_set = first_call, len(plan.calls.set_calls)
            first_call += member.n_set
            member.first_get, member.n_get = first_call, len(plan.calls.get_calls)
            first_call += member.n_get
            member.first_transfer = first_transfer
            member.n_transfers = len(plan.connections)
            first_transfer += len(plan.connections)
        self._group = k.Group(
            len(members),
            ctypes.addressof(self._member_array),
            ctypes.addressof(self._transfer_array),
            ctypes.addressof(self._call_array),
        )
        self._samples = tuple(t for m in members for t in m.tracks if t is not None)
        self.kernel = kernel
        self._step = kernel.step
        self._address = ctypes.addressof(self._group)

    @property
    def address(self) -> int:
        """The C address of the group's ``fx_group`` (what the kernel's functions take)."""
        return self._address

    @property
    def tracks(self) -> tuple[Track, ...]:
        """The members' tracks, in the order a step samples them."""
        return self._samples

    def step(self, t: float, h: float) -> None:
        """Advance every member from ``t`` by ``h``; RunError at the first fault."""
        code = self._step(self._address, t, h)
        if code:
            raise self.fault(code, t, h)
        for track in self._samples:
            track.sample()

    @staticmethod
    def _ended(
        plan: MemberPlan,
        ending: ModelTerminated,
        t: float,
        h: float,
        before_gets: Callable[[], None] | None,
    ) -> RunError:
        """The step completed and the member asks to end the run: get its outputs and sample
        its track as the Python path does before it ends the run (a failing get is the fault).
        """
        if before_gets is not None:
            before_gets()
        for function, args, name in plan.calls.get_calls:
            got = int(function(*args))
            if got > STATUS_WARNING:
                return plan.runner.fault_for(name, got, t + h)
        after = plan.tracks[1]
        if after is not None:
            after.sample()
        return ending

    @classmethod
    def _do_step_fault(
        cls,
        plan: MemberPlan,
        status: int,
        t: float,
        h: float,
        before_gets: Callable[[], None] | None,
    ) -> RunError:
        """A doStep status above Warning: a fault, unless it is FMI 2's ``fmi2Discard`` with
        ``fmi2Terminated`` (asked exactly as the Python path asks)."""
        runner = plan.runner
        if status == STATUS_DISCARD and runner.discard_may_end:
            ending = runner.termination_requested(t, h)
            if ending is not None:
                return cls._ended(plan, ending, t, h, before_gets)
        return runner.fault_for(runner.advance_function, status, t)

    def fault(
        self, code: int, t: float, h: float, before_gets: Callable[[], None] | None = None
    ) -> RunError:
        """The kernel stopped the step from ``t`` with ``code``: record what the Python path
        would have recorded, then name the fault as it does (a ModelTerminated when a member
        asked to end the run).

        ``before_gets`` is called before the outputs of a member that ended the run are got
        (an isolated child says so in its phase, as its Python step does)."""
        index = int(self._group.failed_member)
        for plan in self._members[:index]:
            for track in plan.tracks:
                if track is not None:
                    track.sample()
        plan = self._members[index]
        if code == k.NONFINITE:
            failed = int(self._group.failed_transfer)
            return nonfinite_error(plan.connections[failed], t, plan.views[failed][0])
        before = plan.tracks[0]
        if before is not None:
            before.sample()
        status = int(self._group.failed_status)
        call = int(self._group.failed_call)
        if code == k.SET:
            return plan.runner.fault_for(plan.calls.set_calls[call][2], status, t)
        if code == k.DO_STEP:
            return self._do_step_fault(plan, status, t, h, before_gets)
        if code == k.TERMINATE:
            ending = plan.runner.termination_requested(t, h)
            assert ending is not None  # the kernel stops only when the FMU set the flag
            return self._ended(plan, ending, t, h, before_gets)
        return plan.runner.fault_for(plan.calls.get_calls[call][2], status, t + h)
