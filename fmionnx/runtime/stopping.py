"""Stop requests from the operating system: SIGINT, SIGTERM and SIGHUP end a run cleanly.

CI runners and container runtimes stop a job with SIGTERM, a closed terminal sends SIGHUP; the
default action of both kills the process before it writes anything. Inside :func:`stop_on_signals`
each of them instead raises :class:`StopRequested` (a ``KeyboardInterrupt``, so every place
that already ends a run cleanly on Ctrl-C does so for these too), and any further signal is
noted but ignored, so the results recorded so far can be written without being cut off again.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

#: The signals that stop a run cleanly.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class StopRequested(KeyboardInterrupt):
    """The process was asked to stop by ``signal_name``."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        self.signal_name = signal.Signals(signum).name
        super().__init__(self.signal_name)


def stop_reason(exc: BaseException) -> str:
    """The signal's name for a stop request; ``SIGINT`` for a plain Ctrl-C."""
    return exc.signal_name if isinstance(exc, StopRequested) else "SIGINT"


def stop_behind(exc: BaseException) -> KeyboardInterrupt | None:
    """The stop request ``exc`` was raised because of, if any: a signal's
    :class:`StopRequested` lands wherever the main thread is, and code that catches what it
    calls turns it into an error of its own -- a C extension interrupted while it is imported
    fails with ``ImportError: initialization failed`` (onnxruntime does), a library wraps it.
    Such an error is the stop, not a fault. An error raised ``from None`` replaced what it
    was raised during on purpose: the chain ends there."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return cause
        seen.add(id(cause))
        if cause.__cause__ is not None:
            cause = cause.__cause__
        elif cause.__suppress_context__:
            cause = None
        else:
            cause = cause.__context__
    return None


def exit_code(reason: str | None) -> int:
    """The conventional exit code of a process stopped by ``reason`` (128 + signal number)."""
    if reason is None:
        return 128 + int(signal.SIGINT)
    return 128 + int(signal.Signals[reason])


#: Depth of shielded sections on the main thread, and a stop signal that arrived in one.
_shield_depth = [0]
_held: list[int] = []
#: Depth of :func:`stops_held` blocks on the main thread (part of the shield depth too).
_hold_depth = [0]
#: Depth of :func:`stop_on_signals` blocks whose handler is installed, and how often that
#: handler ran (a signal the main thread acted on, raised, held or ignored).
_converting = [0]
_handler_runs = [0]


def stops_converted() -> bool:
    """Whether stop signals are fmionnx's now (:func:`stop_on_signals` runs on the main
    thread): a program's own handling of them (a notebook's Ctrl-C, a service's SIGTERM) is
    never second-guessed."""
    return _converting[0] > 0


def stop_handler_runs() -> int:
    """How often :func:`stop_on_signals`' handler ran so far: a stop signal that arrived
    (:mod:`.stopnotice` counts them) without the handler running since is one the main thread
    could not act on."""
    return _handler_runs[0]


def _on_main_thread() -> bool:
    """Python runs signal handlers on the main thread only, so only its shields hold them: a
    master run on another thread (two runs in one program) neither holds the main thread's
    signal nor receives it in its own :func:`shield_end`."""
    return threading.get_ident() == threading.main_thread().ident


def holding_stops() -> bool:
    """Whether a :func:`stops_held` block runs (the work after a run's last step): a stop
    signal that comes now is not to end the run, however long that work takes. (A shield
    holds one for a few statements only: a model call stuck inside one is still stuck.)"""
    return _hold_depth[0] > 0


def shield_begin() -> None:
    """Start a few statements that a stop signal must not cut in half (see :func:`shield_end`).

    A stop signal raises :class:`StopRequested` wherever the main thread happens to be; a
    worker lane's hand-over (set the pending step, queue it; take its outcome, clear it) cut
    between two statements would leave the loop waiting for ever for a step that was never
    queued or whose outcome was already taken. Inside a shield the signal is held and raised
    by :func:`shield_end`, once the state is whole again. Only for short, non-blocking code.
    """
    if _on_main_thread():
        _shield_depth[0] += 1


def shield_end() -> None:
    """End a shielded section; raise the stop request held during it, if any."""
    if not _on_main_thread():
        return
    _shield_depth[0] -= 1
    if not _shield_depth[0] and _held:
        raise StopRequested(_held.pop())


@contextlib.contextmanager
def stops_held() -> Iterator[list[str]]:
    """Hold a stop signal for the whole block and never raise it: for the work after a run's
    last step (its models terminated, its results and checks written), which a stop must not
    cut off, however long it takes. The list it yields receives, when the block ends, the
    name of the signal held during it, if any: the caller says so. Nested in a shield or
    another hold, it leaves the signal to the outer one (a shield raises it when it ends).
    Only a signal :func:`stop_on_signals` turns into a stop is held (a program's own Ctrl-C
    handling is its own), and only on the main thread (signals are the main thread's)."""
    late: list[str] = []
    if not _on_main_thread():
        yield late
        return
    held_before = len(_held)
    _shield_depth[0] += 1
    _hold_depth[0] += 1
    try:
        yield late
    finally:
        _hold_depth[0] -= 1
        _shield_depth[0] -= 1
        # Inside a shield the signal stays held for it: a shield delays a stop, never drops it.
        if len(_held) > held_before and not _shield_depth[0]:
            late.append(signal.Signals(_held.pop()).name)


def late_stop_text(signal_name: str) -> str:
    """What a run says of a stop signal that came after its last step (:func:`stops_held`)."""
    return (
        f"{signal_name} came after the run's last step: it was not cut off, and its results "
        "are written in full"
    )


@contextlib.contextmanager
def stop_on_signals(*, process_ends: bool = False) -> Iterator[list[int]]:
    """Turn the first stop signal into :class:`StopRequested`; ignore later ones until the
    block ends (it yields the list of signals received). Off the main thread, a no-op.

    ``process_ends``: the process exits after the block (a command): once a stop signal came,
    later ones stay ignored after it too, so that a second ``SIGTERM`` arriving while the
    process reports and exits cannot kill it before its exit status says how it ended.
    """
    received: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        _handler_runs[0] += 1  # first: the main thread is not stuck (see stop_handler_runs)
        received.append(signum)
        if len(received) == 1:
            if _shield_depth[0]:  # raised by shield_end, when the hand-over is whole
                _held.append(signum)
                return
            raise StopRequested(signum)

    previous = {}
    try:
        for signum in STOP_SIGNALS:
            previous[signum] = signal.signal(signum, handler)
    except ValueError:  # not the main thread: signals stay as they are
        for signum, old in previous.items():
            signal.signal(signum, old)
        yield received
        return
    _converting[0] += 1
    try:
        yield received
    finally:
        _converting[0] -= 1
        for signum, old in previous.items():
            signal.signal(signum, signal.SIG_IGN if received and process_ends else old)
