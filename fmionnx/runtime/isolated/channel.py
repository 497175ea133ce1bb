"""What the supervisor and an isolated model's child process share: pipes and one memory block.

Two pipes carry commands (supervisor -> child) and replies (child -> supervisor). A step is
one byte each way: its times are in the shared *control block*, and its port values in the
shared *data block* behind it, so isolation costs a pipe round trip per step, not a copy of
every value through a pipe. Rare requests (instantiate, setup, produce, terminate) and their
answers are length-prefixed pickles of our own plain data between our own processes.

The control block also holds the *phase* the child is in (an index into the labels it
reported), written before every part of a step, so that when the model kills its process the
supervisor can say which FMI function it died in.
"""

from __future__ import annotations

import ctypes
import mmap
import os
import pickle
import struct
from dataclasses import dataclass

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


class Control:
    """Typed views of the control block: the step's ``t``/``h`` and the child's phase."""

    def __init__(self, block: mmap.mmap) -> None:
        self.times: npt.NDArray[np.float64] = np.ndarray((2,), np.float64, buffer=block)
        self.phase = ctypes.c_int32.from_buffer(block, _PHASE_OFFSET)


def view(block: mmap.mmap, slot: Slot) -> npt.NDArray[np.generic]:
    """The flat array of ``slot`` in a mapped data block."""
    return np.ndarray((slot.count,), np.dtype(slot.dtype), buffer=block, offset=slot.offset)


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
    """One tagged message with a pickled payload."""
    data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
    write_all(fd, tag + _LENGTH.pack(len(data)) + data)


#: The kind of an error reply whose RunError is a model's request to end the run.
TERMINATED = "terminated"


def error_document(exc: RunError) -> tuple[str, str | None, float | None, str | None, str]:
    """(message, port, time, kind, reason) of a RunError raised in the child.

    The kind keeps a :class:`ModelTerminated` (the model's normal end of the run) apart from
    a fault across the process boundary; a fault's kind is None.
    """
    if isinstance(exc, ModelTerminated):
        return (str(exc), exc.port, exc.time, TERMINATED, exc.reason)
    return (str(exc), exc.port, exc.time, None, "")


def error_from(document: tuple[object, ...], component: str) -> RunError:
    """The RunError an error reply describes (a ModelTerminated for a termination request)."""
    padded = (*document, None, None, None, None, "")[:5]
    message, port, time, kind, reason = padded
    where = port if isinstance(port, str) else None
    when = float(time) if isinstance(time, (int, float)) and not isinstance(time, bool) else None
    if kind == TERMINATED:
        return ModelTerminated(
            str(message), reason=str(reason), component=component, port=where, time=when
        )
    return RunError(str(message), component=component, port=where, time=when)


def receive_payload(fd: int) -> object | None:
    """The payload after a tag (None if the pipe closed before it was complete)."""
    header = read_exact(fd, _LENGTH.size)
    if header is None:
        return None
    (size,) = _LENGTH.unpack(header)
    data = read_exact(fd, size)
    return None if data is None else pickle.loads(data)
