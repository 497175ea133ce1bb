"""Stop signals noticed while the main thread is stuck in a model's native call.

Python runs a signal's handler on the main thread, between two bytecodes: a model that never
returns from a call in fmionnx's own process (``--isolate none``, a hung ``fmi2DoStep``)
keeps Ctrl-C and SIGTERM from doing anything until the step timeout (60 s by default)
abandons the run, which then ends as a fault and the stop is lost (a bug hunt). The C-level
handler does run at once, and writes the signal's number to the *wake-up fd*
(:func:`signal.set_wakeup_fd`) when one is set: the run's watchdog thread reads it from
there (:mod:`fmionnx.runtime.watchdog`) and abandons the run as interrupted when the main
thread has not acted on the stop within :data:`STOP_GRACE`.

Only on the main thread (the wake-up fd is the main thread's to set); a wake-up fd set before
(an asyncio loop's) gets every byte passed on and is set again afterwards.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from types import TracebackType

from fmionnx.runtime.stopping import STOP_SIGNALS

#: Seconds a stop signal leaves the main thread to act on it, stuck in the same model call,
#: before the run is abandoned as interrupted. A call that returns within it sees the stop as
#: any other, and the run ends as usual.
STOP_GRACE = 1.0

_STOP_NUMBERS = frozenset(int(s) for s in STOP_SIGNALS)


class StopNotice:
    """While in its ``with`` block on the main thread, the first stop signal that arrived:
    :meth:`poll` from any thread (the watchdog's) says which, and when it was first seen."""

    def __init__(self) -> None:
        self._read = -1
        self._write = -1
        self._before = -1
        #: The first stop signal seen (its number) and when (the ``now`` of that poll).
        self.signum: int | None = None
        self.seen_at = 0.0

    def __enter__(self) -> StopNotice:
        if threading.current_thread() is not threading.main_thread():
            return self
        read, write = os.pipe()
        os.set_blocking(read, False)
        os.set_blocking(write, False)
        try:
            self._before = signal.set_wakeup_fd(write, warn_on_full_buffer=False)
        except ValueError:  # an interpreter that is not the main one
            os.close(read)
            os.close(write)
            return self
        self._read, self._write = read, write
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if self._read < 0:
            return
        signal.set_wakeup_fd(self._before)
        self._pass_on()  # bytes that came since the last poll are the earlier fd's too
        fds, self._read, self._write = (self._read, self._write), -1, -1  # no poll reads them
        for fd in fds:
            with contextlib.suppress(OSError):
                os.close(fd)

    def poll(self, now: float) -> int | None:
        """The first stop signal that arrived so far (None: none), reading what came since
        the last poll."""
        for number in self._pass_on():
            if self.signum is None and number in _STOP_NUMBERS:
                self.signum, self.seen_at = number, now
        return self.signum

    def _pass_on(self) -> bytes:
        """What came down the pipe since the last read, also written to the fd set before."""
        if self._read < 0:
            return b""
        try:
            data = os.read(self._read, 512)
        except (BlockingIOError, OSError):
            return b""
        if data and self._before >= 0:
            with contextlib.suppress(OSError):
                os.write(self._before, data)
        return data
