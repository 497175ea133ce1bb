"""What the supervisor and an isolated model's child process share: pipes and one memory block.

Two pipes carry commands (supervisor -> child) and replies (child -> supervisor). A step is
one byte each way: its times are in the shared *control block*, and its port values in the
shared *data block* behind it, so isolation costs a pipe round trip per step, not a copy of
every value through a pipe. Rare requests (instantiate, setup, produce, terminate) are
length-prefixed pickles: the child trusts its supervisor. The child's answers are **JSON**,
bounded in size and checked field by field before use: the child runs a model that may be
hostile, which can write to the reply pipe and the shared block, and must not be able to make
the supervisor run code (a pickle could) or read outside the block (see :func:`parse_layout`).

The control block also holds the *phase* the child is in (an index into the labels it
reported), written before every part of a step, so that when the model kills its process the
supervisor can say which FMI function it died in.

And two sequence counters, one per direction, for the *hybrid wait* (:class:`Spinner`): a side
that has written a whole message to its pipe then stores how many it has written so far; the
other side spins briefly on that counter before it blocks on the pipe. On an idle machine a
process blocked in the kernel costs a wake-up of tens of microseconds each time (the core went
to sleep); spinning keeps it awake for the round trips that come back quickly. The counters
are only ever a hint ("maybe ready"): the model can write any value there, so the reader never
trusts one for more than ending its spin early; it then waits on the pipe exactly as it would
have without a counter (with the step timeout's ``poll`` on the supervisor's side).
"""

from __future__ import annotations

import ctypes
import json
import mmap
import os
import pickle
import select
import struct
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from fmionnx.core.errors import ModelTerminated, RunError

#: Bytes of the control block; the data block starts here (a page boundary, as mmap wants).
CONTROL_SIZE = mmap.ALLOCATIONGRANULARITY

#: Commands and replies.
STEP = b"S"
CALL = b"C"
OK = b"k"
ERROR = b"e"

#: Phases before the step labels (the child reports those at setup).
PHASE_INSTANTIATE = 0
PHASE_SETUP = 1
PHASE_TERMINATE = 2
PHASE_PRODUCE = 3
FIRST_STEP_PHASE = 4
FIXED_PHASES = (
    "loading and instantiating the model",
    "initialization",
    "terminate",
    "producing a lazy output",
)

_LENGTH = struct.Struct("<I")
_PHASE_OFFSET = 16
_REQUESTS_OFFSET = 24
_REPLIES_OFFSET = 28
#: Counters are stored modulo 2**32 (a run may step more often than that).
COUNTER_MASK = 0xFFFFFFFF

#: The largest reply the supervisor reads (a layout of thousands of ports fits easily).
MAX_REPLY_BYTES = 1 << 20

#: Element types a port slot may have (numpy kinds: float, signed, unsigned, bool).
_SLOT_KINDS = frozenset("fiub")


class MalformedReplyError(Exception):
    """The child's answer is not what the protocol allows (a broken or hostile model)."""


@dataclass(frozen=True, slots=True)
class Slot:
    """One port's values in the data block: ``count`` elements of ``dtype`` at ``offset``."""

    port: str
    is_input: bool
    dtype: str
    offset: int
    count: int


@dataclass(frozen=True, slots=True)
class Layout:
    """The child's answer to setup: where each port lives, lazy outputs, step phase labels."""

    slots: tuple[Slot, ...]
    size: int
    lazy_outputs: frozenset[str]
    step_labels: tuple[str, ...]
    #: Whether the native kernel serves the steps in the child (:mod:`.handover`).
    native: bool = False


class Control:
    """Typed views of the control block: the step's ``t``/``h``, the child's phase, and the
    commands written by the supervisor (``requests``) and replies written by the child
    (``replies``) so far, modulo 2**32; each counter is written by one side only."""

    def __init__(self, block: mmap.mmap) -> None:
        self.times: npt.NDArray[np.float64] = np.ndarray((2,), np.float64, buffer=block)
        self.phase = ctypes.c_int32.from_buffer(block, _PHASE_OFFSET)
        self.requests = ctypes.c_uint32.from_buffer(block, _REQUESTS_OFFSET)
        self.replies = ctypes.c_uint32.from_buffer(block, _REPLIES_OFFSET)


#: How many times a missed spin doubles the waits that skip theirs, at most (:class:`Spinner`).
MAX_BACKOFF = 6


def _nothing() -> None:
    """A spin's pause when it need not give way."""


class Spinner:
    """The first half of a hybrid wait: spin on a counter for at most ``budget_ns``.

    :meth:`wait` returns as soon as the counter differs from the value the waiting side has
    consumed (the message is probably in the pipe: reading it will not sleep), or when the
    budget is spent; the caller then reads or polls its pipe as it always did. Spinning pays
    only when answers come back within the budget, so a miss doubles the number of waits that
    skip the spin and block at once (up to ``2**max_backoff - 1``) and a hit resets it: a model
    whose steps are slow, or a child whose next command comes late because the master steps
    others in between, costs a wasted spin once in many waits, not a core.
    """

    __slots__ = ("_backoff", "_skip", "budget_ns", "hits", "max_backoff", "polite", "spins")

    def __init__(
        self, budget_ns: int, max_backoff: int = MAX_BACKOFF, *, polite: bool = False
    ) -> None:
        self.budget_ns = budget_ns
        self.polite = polite
        self.max_backoff = max_backoff
        self._backoff = 0
        self._skip = 0
        #: Waits that spun, and those whose counter moved within the budget (tests read them).
        self.spins = 0
        self.hits = 0

    def wait(self, counter: ctypes.c_uint32, seen: int) -> bool:
        """Spin while ``counter`` equals ``seen``; True if it moved within the budget."""
        if self.budget_ns <= 0:
            return False
        if self._skip:
            self._skip -= 1
            return False
        self.spins += 1
        clock = time.perf_counter_ns
        deadline = clock() + self.budget_ns
        pause = os.sched_yield if self.polite else _nothing
        while counter.value == seen:
            pause()
            if clock() >= deadline:
                self._backoff = min(self._backoff + 1, self.max_backoff)
                self._skip = (1 << self._backoff) - 1
                return False
        self._backoff = 0
        self.hits += 1
        return True


def view(block: mmap.mmap, slot: Slot) -> npt.NDArray[np.generic]:
    """The flat array of ``slot`` in a mapped data block."""
    return np.ndarray((slot.count,), np.dtype(slot.dtype), buffer=block, offset=slot.offset)


def readable(fd: int, timeout: float | None) -> bool:
    """Whether ``fd`` has something to read, or its other end closed, within ``timeout``
    seconds (None: wait for ever)."""
    return _ready(fd, select.POLLIN | select.POLLHUP, timeout)


def writable(fd: int, timeout: float) -> bool:
    """Whether a small message can be written to ``fd`` without blocking, or its other end
    closed (the write then fails at once), within ``timeout`` seconds."""
    return _ready(fd, select.POLLOUT, timeout)


def _ready(fd: int, events: int, timeout: float | None) -> bool:
    poller = select.poll()
    poller.register(fd, events)
    return bool(poller.poll(None if timeout is None else max(timeout, 0.0) * 1000.0))


def write_all(fd: int, data: bytes) -> None:
    """``os.write`` until everything is written (pipes may take less at once)."""
    written = memoryview(data)
    while written:
        n = os.write(fd, written)
        written = written[n:]


def read_exact(fd: int, size: int) -> bytes | None:
    """``size`` bytes, or None when the other end closed the pipe first."""
    parts = bytearray()
    while len(parts) < size:
        chunk = os.read(fd, size - len(parts))
        if not chunk:
            return None
        parts += chunk
    return bytes(parts)


def send(fd: int, tag: bytes, payload: object) -> None:
    """One tagged command with a pickled payload (supervisor -> child only)."""
    data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
    write_all(fd, tag + _LENGTH.pack(len(data)) + data)


#: The kind of an error reply whose RunError is a model's request to end the run.
TERMINATED = "terminated"


def error_document(exc: RunError) -> list[str | float | None]:
    """[message, port, time, kind, reason] of a RunError raised in the child (JSON).

    The kind keeps a :class:`ModelTerminated` (the model's normal end of the run) apart from
    a fault across the process boundary; a fault's kind is None.
    """
    if isinstance(exc, ModelTerminated):
        return [str(exc), exc.port, exc.time, TERMINATED, exc.reason]
    return [str(exc), exc.port, exc.time, None, ""]


#: An error reply, checked: (message, port, time, kind, reason).
ParsedError = tuple[str, str | None, float | None, str | None, str]


def error_from(parsed: ParsedError, component: str) -> RunError:
    """The RunError a checked error reply describes (a ModelTerminated for a termination)."""
    message, port, time, kind, reason = parsed
    if kind == TERMINATED:
        return ModelTerminated(message, reason=reason, component=component, port=port, time=time)
    return RunError(message, component=component, port=port, time=time)


def receive_payload(fd: int) -> object | None:
    """A command's payload after its tag (None if the pipe closed first); child side only."""
    data = _framed(fd, None)
    return None if data is None else pickle.loads(data)


def reply(fd: int, tag: bytes, payload: Any) -> None:
    """One tagged reply with a JSON payload (child -> supervisor)."""
    data = json.dumps(payload).encode()
    write_all(fd, tag + _LENGTH.pack(len(data)) + data)


def receive_reply(fd: int) -> Any:
    """A reply's JSON payload after its tag; None if the pipe closed first.

    Raises MalformedReplyError for a reply too large or not JSON.
    """
    data = _framed(fd, MAX_REPLY_BYTES)
    if data is None:
        return None
    try:
        return json.loads(data)
    except ValueError:
        raise MalformedReplyError("a reply that is not JSON") from None


def _framed(fd: int, limit: int | None) -> bytes | None:
    header = read_exact(fd, _LENGTH.size)
    if header is None:
        return None
    (size,) = _LENGTH.unpack(header)
    if limit is not None and size > limit:
        raise MalformedReplyError(f"a reply of {size} bytes (at most {limit})")
    return read_exact(fd, size)


def layout_document(layout: Layout) -> dict[str, Any]:
    """The JSON form of a layout (the child's answer to setup)."""
    return {
        "slots": [[s.port, s.is_input, s.dtype, s.offset, s.count] for s in layout.slots],
        "size": layout.size,
        "lazy_outputs": sorted(layout.lazy_outputs),
        "step_labels": list(layout.step_labels),
        "native": layout.native,
    }


def parse_layout(document: Any, ports: frozenset[str], available: int) -> Layout:
    """A layout from the child's JSON, checked: known ports, numeric types, every slot inside
    the ``available`` bytes of the data block (so no view can reach outside the mapping)."""
    try:
        slots = []
        for port, is_input, dtype, offset, count in document["slots"]:
            if port not in ports or not isinstance(is_input, bool):
                raise MalformedReplyError(f"a slot for an unknown port {port!r}")
            element = np.dtype(str(dtype))
            numbers = (offset, count)
            if element.kind not in _SLOT_KINDS or element.itemsize > 8:
                raise MalformedReplyError(f"a slot of type {dtype!r}")
            if not all(isinstance(n, int) and not isinstance(n, bool) for n in numbers):
                raise MalformedReplyError("a slot with a non-integer offset or count")
            if offset < 0 or count < 0 or offset + count * element.itemsize > available:
                raise MalformedReplyError(f"a slot outside the shared block ({port!r})")
            slots.append(Slot(port, is_input, element.str, offset, count))
        size = document["size"]
        lazy = frozenset(str(p) for p in document["lazy_outputs"]) & ports
        labels = tuple(str(label)[:200] for label in document["step_labels"][:16])
        native = document.get("native", False) is True
    except (KeyError, TypeError, ValueError) as exc:
        raise MalformedReplyError(f"a malformed layout ({exc})") from None
    if not isinstance(size, int) or not 0 <= size <= available:
        raise MalformedReplyError("a layout larger than the shared block")
    return Layout(tuple(slots), size, lazy, labels, native)


def parse_error(document: Any) -> ParsedError:
    """(message, port, time, kind, reason) of an error reply, checked and bounded."""
    if not isinstance(document, list) or len(document) not in (3, 5):
        raise MalformedReplyError("a malformed error reply")
    message, port, time, kind, reason = (*document, None, "")[:5]
    text = str(message)[:2000]
    where = port if isinstance(port, str) else None
    when = float(time) if isinstance(time, (int, float)) and not isinstance(time, bool) else None
    return text, where, when, TERMINATED if kind == TERMINATED else None, str(reason)[:500]
