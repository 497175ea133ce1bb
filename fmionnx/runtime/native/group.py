"""One native group: consecutive FMI 2 co-simulation FMUs stepped by one C call.

The group owns the C structures describing its members (instance, FMI function pointers,
value-reference and value arrays of the runner, incoming connections as pointer ranges). Its
:meth:`NativeGroup.step` replaces the members' Python work at one communication point —
transfers, set, doStep, get — and then samples the members' recorder tracks, which is
equivalent to sampling them between the members' steps: during a group step each member's
input buffer is written only by its own transfers and its output buffer only by its own get.
On a fault, the tracks are sampled exactly as far as the Python path would have got, and
the RunError is the one the Python path raises (same function, status, time, FMU log); a
member whose ``fmi2Discard`` asks to terminate ends the run as in Python (ModelTerminated).
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from dataclasses import dataclass

from fmionnx.compile.ir import Connection
from fmionnx.core.errors import RunError
from fmionnx.core.runner import Buffer
from fmionnx.kinds.fmu.fmi2 import Fmi2CoSimulation
from fmionnx.kinds.fmu.runner import FMI_DISCARD, FMI_WARNING, Fmi2CsCalls, FmuRunner
from fmionnx.kinds.fmu.values import RawCall
from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.transfer import nan_error


@dataclass(frozen=True)
class MemberPlan:
    """Everything one member contributes: its runner, calls, connections and their views."""

    name: str
    runner: FmuRunner
    calls: Fmi2CsCalls
    connections: tuple[Connection, ...]
    views: tuple[tuple[Buffer, Buffer], ...]
    tracks: tuple[Track | None, Track | None]


def _address(obj: object) -> int | None:
    """The C address of a ctypes function pointer."""
    return ctypes.cast(obj, ctypes.c_void_p).value  # type: ignore[arg-type]


def _call_arrays(calls: Sequence[RawCall]) -> tuple[int | None, int, int | None]:
    """(vr array address, count, value array address) of a runner's only set/get call."""
    if not calls:
        return None, 0, None
    _, (_, vrs, _count, values), _ = calls[0]
    if not (isinstance(vrs, ctypes.Array) and isinstance(values, ctypes.Array)):
        msg = f"unexpected arguments of {calls[0][2]}"
        raise TypeError(msg)
    return ctypes.addressof(vrs), len(vrs), ctypes.addressof(values)


class NativeGroup:
    """Members of one period, in execution order, stepped by ``fx_group_step``."""

    def __init__(self, kernel: k.Kernel, members: Sequence[MemberPlan], period_steps: int) -> None:
        self.names = tuple(m.name for m in members)
        self.period_steps = period_steps
        self._members = tuple(members)
        transfers = [(c, v) for m in members for c, v in zip(m.connections, m.views, strict=True)]
        self._transfer_array = (k.TransferSpec * max(1, len(transfers)))()
        for i, (connection, (src, dst)) in enumerate(transfers):
            spec = self._transfer_array[i]
            spec.src = src.ctypes.data
            spec.dst = dst.ctypes.data
            spec.count = int(src.size)
            spec.factor = connection.factor
            spec.offset = connection.offset
            spec.identity = int(connection.factor == 1.0 and connection.offset == 0.0)
        self._member_array = (k.Member * len(members))()
        first = 0
        for i, plan in enumerate(members):
            member = self._member_array[i]
            calls = plan.calls
            member.instance = calls.instance.value
            member.do_step = _address(calls.do_step)
            member.in_vrs, member.n_in, member.in_values = _call_arrays(calls.set_calls)
            member.out_vrs, member.n_out, member.out_values = _call_arrays(calls.get_calls)
            member.set_real = _address(calls.set_calls[0][0]) if calls.set_calls else None
            member.get_real = _address(calls.get_calls[0][0]) if calls.get_calls else None
            member.first_transfer = first
            member.n_transfers = len(plan.connections)
            first += len(plan.connections)
        self._group = k.Group(
            len(members),
            ctypes.addressof(self._member_array),
            ctypes.addressof(self._transfer_array),
        )
        self._samples = tuple(t for m in members for t in m.tracks if t is not None)
        self._step = kernel.step
        self._address = ctypes.addressof(self._group)

    def step(self, t: float, h: float) -> None:
        """Advance every member from ``t`` by ``h``; RunError at the first fault."""
        code = self._step(self._address, t, h)
        if code:
            raise self._fault(code, t, h)
        for track in self._samples:
            track.sample()

    @staticmethod
    def _termination(plan: MemberPlan, status: int, t: float, h: float) -> RunError | None:
        """A ``fmi2Discard`` from a member that asks to end the run (``fmi2Terminated``).

        The kernel stops at any status above Warning; the Python side asks the FMU whether
        it terminated, exactly as the Python path does, and then gets the completed step's
        outputs and samples its track as the Python path would before ending the run.
        """
        if status != FMI_DISCARD or not isinstance(plan.runner, Fmi2CoSimulation):
            return None
        ending = plan.runner.termination_requested(t, h)
        if ending is None:
            return None
        for function, args, name in plan.calls.get_calls:
            got = int(function(*args))
            if got > FMI_WARNING:
                return plan.runner.fault_for(name, got, t + h)
        after = plan.tracks[1]
        if after is not None:
            after.sample()
        return ending

    def _fault(self, code: int, t: float, h: float) -> RunError:
        """Record what the Python path would have recorded, then name the fault as it does."""
        index = int(self._group.failed_member)
        for plan in self._members[:index]:
            for track in plan.tracks:
                if track is not None:
                    track.sample()
        plan = self._members[index]
        if code == k.NAN:
            return nan_error(plan.connections[int(self._group.failed_transfer)], t)
        before = plan.tracks[0]
        if before is not None:
            before.sample()
        status = int(self._group.failed_status)
        if code == k.SET:
            return plan.runner.fault_for(plan.calls.set_calls[0][2], status, t)
        if code == k.DO_STEP:
            ending = self._termination(plan, status, t, h)
            return ending or plan.runner.fault_for("fmi2DoStep", status, t)
        return plan.runner.fault_for(plan.calls.get_calls[0][2], status, t + h)
