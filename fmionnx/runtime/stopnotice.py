"""Stop signals the main thread cannot act on, stuck in a model's native call.

Python runs a signal's handler on the main thread, between two bytecodes: a model that never
returns from a call in fmionnx's own process (``--isolate none``, a hung ``fmi2DoStep``)
keeps Ctrl-C and SIGTERM from doing anything until the step timeout (60 s by default)
abandons the run, which then ended as a fault and the stop was lost (a bug hunt). The C-level
handler does run at once, and writes the signal's number to the *wake-up fd*
(:func:`signal.set_wakeup_fd`) when one is set: the run's watchdog thread reads it from
there (:mod:`fmionnx.runtime.watchdog`). A signal is *pending* from its byte on until
fmionnx's handler is seen to have run (:func:`.stopping.stop_handler_runs`): the handler runs
as soon as the main thread executes Python, even inside a shield that holds the stop, so a
pending signal means the main thread is in native code. Pending for
:data:`STOP_GRACE`, the run is abandoned as interrupted.

Only while fmionnx turns stop signals into stops (:func:`.stopping.stops_converted`: the
command line, not a program's own handling of them) and only on the main thread (the wake-up
fd is the main thread's to set); a wake-up fd set before (an asyncio loop's) gets every byte
passed on and is set again afterwards.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from types import TracebackType

from fmionnx.runtime.stopping import STOP_SIGNALS, stop_handler_runs, stops_converted

#: Seconds a stop signal may stay pending (the main thread stuck in native code) before the
#: run is abandoned as interrupted. A call that returns within it lets the handler run, and
#: the run ends as any stopped run does.
STOP_GRACE = 1.0
#: Seconds a stop the main thread acted on may wait for one in-process call (a step on a
#: worker lane, which the loop waits for before it ends the run) before the run is abandoned
#: as interrupted all the same: the loop's thread runs Python, but the stop would otherwise
#: wait for the step timeout and end as a fault (the second review of this change).
ACTED_GRACE = 5.0

_STOP_NUMBERS = frozenset(int(s) for s in STOP_SIGNALS)


class StopNotice:
    """While in its ``with`` block: :meth:`poll` (from any thread: the watchdog's) says which
    stop signal is pending, and since when."""

    def __init__(self) -> None:
        self._read = -1
        self._write = -1
        self._before = -1
        #: Serialises reading the pipe with closing it (a closed fd's number is reused).
        self._lock = threading.Lock()
        #: Stop signals seen since the handler last ran, its run count then, and whether
        #: that count changed at the last poll.
        self._unacted = 0
        self._runs_seen = 0
        self._just_acted = False
        #: The first stop signal that came (its number) and when it was seen; since when one
        #: is pending (the ``now`` of the poll that saw it so; None: none is).
        self.signum: int | None = None
        self.first_at = 0.0
        self.pending_since: float | None = None

    def __enter__(self) -> StopNotice:
        if threading.current_thread() is not threading.main_thread() or not stops_converted():
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
        self._runs_seen = stop_handler_runs()
        self._read, self._write = read, write
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        with self._lock:
            if self._read < 0:
                return
            signal.set_wakeup_fd(self._before)
            self._pass_on()  # bytes that came since the last poll are the earlier fd's too
            for fd in (self._read, self._write):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self._read = self._write = -1

    def poll(self, now: float) -> int | None:
        """The first stop signal that came so far (None: none), reading what came since the
        last poll; :attr:`pending_since` says whether the main thread has yet to act on it.

        A signal is pending from its byte on until the handler is seen to have run: a run of
        it means the main thread executes Python, and acted on every stop before (two quick
        Ctrl-C give two bytes and, coalesced, one run of the handler). The C handler may
        write its byte just after the main thread ran the Python one (a signal delivered to
        another thread): bytes read in the poll after the count changed are taken as those
        of the signals it acted on."""
        runs = stop_handler_runs()  # before the pipe: a byte read after it is no older
        with self._lock:
            came = [n for n in self._pass_on() if n in _STOP_NUMBERS]
        if runs != self._runs_seen:
            self._runs_seen, self._unacted, self._just_acted = runs, 0, True
        elif self._just_acted:
            self._just_acted = False
        else:
            self._unacted += len(came)
        if came and self.signum is None:
            self.signum, self.first_at = came[0], now
        if not self._unacted:
            self.pending_since = None
        elif self.pending_since is None:
            self.pending_since = now
        return self.signum

    def _pass_on(self) -> bytes:
        """What came down the pipe since the last read, also written to the fd set before."""
        if self._read < 0:
            return b""
        try:
            data = os.read(self._read, 512)
        except OSError:  # nothing there (non-blocking), or closed
            return b""
        if data and self._before >= 0:
            with contextlib.suppress(OSError):
                os.write(self._before, data)
        return data
