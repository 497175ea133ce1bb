"""An isolated FMU's step hand-over in C: both ends of the pipe round trip, in the native kernel.

A step of an isolated component is one byte to its child and one byte back (:mod:`.channel`).
In Python, each end spent tens of microseconds around the two system calls -- the supervisor
writing, spinning and polling, the child reading, copying the ports, making the FMI calls and
answering -- and most of it with cold caches, since the master renders and infers between two
steps of an FMU: 120-150 µs a round trip in the reference scenario against 35 µs for a lone
FMU. The kernel (``fmi2_group.c``: ``fx_link_step``, ``fx_serve``) now does the same work
without a Python instruction:

* :class:`Link`, the supervisor's end, writes the command, spins as :class:`~.channel.Spinner`
  does and polls for the reply, at most 20 ms (a longer step is waited for in Python, where a
  stop signal that came just before the poll is acted on); Python sees the reply's first byte,
  or why there is none (the child gone, the timeout, a signal), and goes on as before. A
  signal that interrupts the write leaves the command unwritten.
* :class:`Server`, the child's end, serves step commands in a loop: the ports copied from the
  shared block, the runner's set, doStep and get calls made as ``fx_group_step`` makes them
  for a group of one (the phase stored before each part, as the Python child does), the
  outputs copied back, the answer written. Any other command, a fault, a closed pipe or a
  signal returns to the Python loop (:mod:`.server`), which answers as before; a fault is
  named by :meth:`~fmionnx.runtime.native.group.NativeGroup.fault`, as in-process.

Used where the native kernel is (``FMIONNX_NATIVE``, :mod:`fmionnx.runtime.native.grouping`)
and, in the child, for a runner the kernel can step (an FMI 2 or FMI 3 co-simulation FMU whose
ports are plain numbers); otherwise each end keeps its Python code, which gives the same
results, faults and phases.
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from fmionnx.core.cosim import NativeSteppable
from fmionnx.core.runner import Buffer, Runner
from fmionnx.runtime.isolated import channel
from fmionnx.runtime.native import kernel as k

if TYPE_CHECKING:
    from fmionnx.runtime.native.group import NativeGroup

#: The largest timeout ``poll`` takes, in milliseconds.
_MAX_POLL_MS = 2**31 - 1
#: Counters are compared modulo 2**32 (:data:`~.channel.COUNTER_MASK`).
_MASK = channel.COUNTER_MASK


def native_kernel() -> k.Kernel | None:
    """The kernel the native switch allows in this process now, or None (Python ends)."""
    if sys.platform == "win32":  # the kernel's hand-over is POSIX, as isolation is
        return None
    return _kernel_for(os.environ.get(k.SWITCH_ENV, "").strip())


@functools.cache
def _kernel_for(setting: str) -> k.Kernel | None:
    if setting == "0" or setting not in k.SETTINGS:  # as the in-process kernel's switch reads
        return None
    kernel = k.load_kernel(build=setting == "build")
    return None if isinstance(kernel, str) else kernel


def _spin(budget_ns: int, *, polite: bool) -> k.SpinSpec:
    return k.SpinSpec(budget_ns, int(polite), channel.MAX_BACKOFF, 0, 0, 0, 0)


def poll_milliseconds(timeout: float | None) -> int:
    """A wait of ``timeout`` seconds as ``poll`` takes it (-1: for ever), rounded up."""
    if timeout is None:
        return -1
    return min(_MAX_POLL_MS, math.ceil(max(timeout, 0.0) * 1000.0))


class Link:
    """The supervisor's end: one step command written, its reply's first byte read."""

    def __init__(
        self,
        kernel: k.Kernel,
        commands: int,
        replies: int,
        control: channel.Control,
        timeout: float | None,
        spin_ns: int,
    ) -> None:
        self._spec = k.LinkSpec(
            commands,
            replies,
            ctypes.addressof(control.requests),
            ctypes.addressof(control.replies),
            0,
            0,
            poll_milliseconds(timeout),
            0,
            0,
            _spin(spin_ns, polite=False),
        )
        self._control = control  # the block the counters' addresses point into stays mapped
        self._address = ctypes.addressof(self._spec)
        self._call = kernel.link_step

    def prepare(self, sent: int, answered: int) -> None:
        """The counters so far, before :meth:`call` (so that :meth:`written` and
        :meth:`answered` compare with them whatever interrupts the call)."""
        spec = self._spec
        spec.sent = sent & _MASK
        spec.answered = answered & _MASK

    def call(self, *, spin: bool) -> int:
        """Write a step command and wait for the reply; a ``LINK_*`` code of
        :mod:`~fmionnx.runtime.native.kernel`."""
        return self._call(self._address, int(spin))

    @property
    def tag(self) -> bytes:
        """The reply's first byte (after ``LINK_REPLY``)."""
        return bytes((self._spec.tag & 0xFF,))

    def written(self, sent: int) -> bool:
        """Whether the last :meth:`call` wrote its command (``sent``: the count before it)."""
        return bool(self._spec.sent != sent & _MASK)

    def answered(self, answered: int) -> bool:
        """Whether the last :meth:`call` read a reply's first byte (``answered``: the count
        before it)."""
        return bool(self._spec.answered != answered & _MASK)

    @property
    def error(self) -> int:
        """The ``errno`` of ``LINK_ERRNO``."""
        return int(self._spec.error)

    @property
    def spins(self) -> int:
        """Waits that spun so far."""
        return int(self._spec.spin.spins)


class Server:
    """The child's end: step commands served by the kernel until anything else comes."""

    def __init__(
        self,
        kernel: k.Kernel,
        group: NativeGroup,
        block: channel.Control,
        commands: int,
        replies: int,
        copies: tuple[Sequence[tuple[Buffer, Buffer]], Sequence[tuple[Buffer, Buffer]]],
        spin_ns: int,
    ) -> None:
        self.group = group
        self._pairs = copies  # the buffers the kernel copies between, kept alive with it
        inputs, outputs = copies
        self._inputs = _copies([(own, shared) for shared, own in inputs])
        self._outputs = _copies([(shared, own) for shared, own in outputs])
        self._spec = k.ServerSpec(
            commands,
            replies,
            ctypes.addressof(block.requests),
            ctypes.addressof(block.replies),
            ctypes.addressof(block.phase),
            block.times.ctypes.data,
            0,
            0,
            channel.FIRST_STEP_PHASE,
            0,
            0,
            0,
            group.address,
            ctypes.addressof(self._inputs),
            len(inputs),
            ctypes.addressof(self._outputs),
            len(outputs),
            _spin(spin_ns, polite=True),
        )
        self._control = block
        self._address = ctypes.addressof(self._spec)
        self._call = kernel.serve

    def serve(self, consumed: int, written: int) -> tuple[int, int, int]:
        """Serve steps (``consumed``, ``written``: the counters so far); returns the kernel's
        code and how many commands it read and replies it wrote meanwhile."""
        spec = self._spec
        spec.consumed = consumed & _MASK
        spec.written = written & _MASK
        code = self._call(self._address)
        return code, (spec.consumed - consumed) & _MASK, (spec.written - written) & _MASK

    @property
    def op(self) -> bytes:
        """The command that was not a step (after ``SERVE_COMMAND``)."""
        return bytes((self._spec.op & 0xFF,))

    @property
    def code(self) -> int:
        """The kernel's code of the failed step (after ``SERVE_FAULT``)."""
        return int(self._spec.code)

    @property
    def error(self) -> int:
        """The ``errno`` of ``LINK_ERRNO``."""
        return int(self._spec.error)


def _copies(pairs: Sequence[tuple[Buffer, Buffer]]) -> ctypes.Array[k.CopySpec]:
    """``(dst, src)`` buffer pairs as the kernel's copies."""
    array = (k.CopySpec * max(1, len(pairs)))()
    for spec, (dst, src) in zip(array, pairs, strict=False):
        spec.dst = dst.ctypes.data
        spec.src = src.ctypes.data
        spec.size = src.nbytes
    return array


def _plain(pairs: Sequence[tuple[Buffer, Buffer]]) -> bool:
    """Whether every pair is two contiguous buffers of one type and size (a byte copy)."""
    return all(
        a.dtype == b.dtype
        and a.size == b.size
        and a.flags.c_contiguous
        and b.flags.c_contiguous
        and a.dtype.isnative
        for a, b in pairs
    )


def serving(
    runner: Runner,
    block: channel.Control,
    pipes: tuple[int, int],
    copies: tuple[Sequence[tuple[Buffer, Buffer]], Sequence[tuple[Buffer, Buffer]]],
    phases: int,
    spin_ns: int,
) -> Server | None:
    """The kernel's end for ``runner`` once set up, or None where the Python loop steps it.

    ``copies``: the (shared, own) buffers of its inputs and outputs; ``phases``: how many step
    phases the Python child would go through (the kernel's are set, doStep, get).
    """
    if not isinstance(runner, NativeSteppable) or runner.native_problem() is not None:
        return None
    calls = runner.cs_calls()
    if calls is None or phases != 3 or not all(_plain(pairs) for pairs in copies):
        return None
    kernel = native_kernel()
    if kernel is None:
        return None
    from fmionnx.runtime.native.group import MemberPlan, NativeGroup

    name = runner.component.name
    try:
        group = NativeGroup(kernel, [MemberPlan(name, runner, calls, (), (), (None, None))], 1)
    except TypeError:  # a call whose values the kernel has no element type for
        return None
    return Server(kernel, group, block, *pipes, copies, spin_ns)
