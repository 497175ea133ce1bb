"""Both ends of an isolated FMU's step hand-over in the native kernel (``runtime/isolated/handover``).

The supervisor's write-and-wait and the child's serving of steps (port copies, set, doStep,
get, answer) run in C where the kernel is available, and in Python with ``FMIONNX_NATIVE=0``.
Real child processes step real FMUs either way; every check compares the two: the same values,
the same faults at the same time in the same FMI function, and a run.json that says which.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import threading
import time
from collections.abc import Callable

import pytest

import fmionnx
from fmionnx.runtime.isolated import proxy
from fmionnx.runtime.isolated.proxy import IsolatedRunner
from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from fmionnx.runtime.stopping import StopRequested, stop_on_signals
from tests.backends.isolated_runner import (
    assert_completed_alike,
    isolated,
    isolated_chain,
    lone_component,
    unstarted,
)

SYSTEM = """
fmionnx: 1
name: faulty
run: {{stop: 0.5, step: 0.01}}
components:
  bad: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  gain: {{kind: fmu, path: {gain}}}
connections:
  - bad.y -> gain.u
"""
ERROR, DISCARD, SEGFAULT, TERMINATE, PRINT = 0, 2, 3, 10, 11
NATIVE = "runs in a child process (--isolate), stepped there by the native kernel"
PYTHON = "runs in a child process (--isolate)"


def _both(monkeypatch, run) -> dict[str, RunResult]:
    """``run()`` with the kernel's ends of the hand-over, then with Python's."""
    results = {}
    for setting in ("1", "0"):
        monkeypatch.setenv("FMIONNX_NATIVE", setting)
        results[setting] = run()
    return results


@pytest.mark.parametrize(
    ("mode", "status"),
    [
        (ERROR, RunStatus.FAULT),
        (DISCARD, RunStatus.FAULT),
        (SEGFAULT, RunStatus.FAULT),
        (TERMINATE, RunStatus.COMPLETED),  # the model ended the run after its step
        (PRINT, RunStatus.COMPLETED),
    ],
)
def test_an_isolated_fmu_ends_alike_through_the_kernel_and_python(
    fixture_fmu, write_system, monkeypatch, mode: int, status: RunStatus
) -> None:
    path = write_system(
        SYSTEM.format(faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=mode)
    )
    options = RunOptions(isolate=frozenset({"bad", "gain"}))
    results = _both(monkeypatch, lambda: fmionnx.load(path).run(options=options))
    kernel, python = results["1"], results["0"]
    assert kernel.status is python.status is status
    assert str(kernel.error) == str(python.error)
    if kernel.error is not None:
        assert "fmi2DoStep" in str(kernel.error)
    for name in ("time", "bad.y", "gain.y"):
        assert kernel[name].tobytes() == python[name].tobytes()
    assert kernel.details["native_python.bad"] == NATIVE
    assert python.details["native"] is False  # the kernel off: no component says more


def test_an_isolated_fmi3_model_ends_the_run_alike_through_the_kernel_and_python(
    fixture_fmu, monkeypatch
) -> None:
    """FMI 3's terminateSimulation stops the kernel's step; the child gets the outputs."""
    system = fmionnx.load(fixture_fmu("Vector3"), step=0.1)

    def run() -> RunResult:
        return system.run(isolate="fmus", stop_time=2.0, params={"stopAt": 0.5})

    results = _both(monkeypatch, run)
    kernel, python = results["1"], results["0"]
    assert kernel.status is python.status is RunStatus.COMPLETED
    assert kernel.ended_by == python.ended_by
    assert kernel.ended_by is not None
    assert kernel.steps_done == python.steps_done == 5
    for name in kernel.signals:
        assert kernel[name].tobytes() == python[name].tobytes()
    assert kernel.details[f"native_python.{system.compiled.name}"] == NATIVE


def test_isolated_chains_give_the_same_bytes_through_the_kernel_and_python(
    fixture_fmu, write_system, monkeypatch
) -> None:
    """Two Gains the kernel steps in their children, and a model-exchange FMU it does not."""
    system, options = isolated_chain(fixture_fmu, write_system)
    results = _both(monkeypatch, lambda: system.run(options=options))
    assert_completed_alike(results["0"], results["1"])
    assert results["1"].details["native_python.a"] == NATIVE
    assert results["1"].details["native_python.b"] == PYTHON  # integrated in Python


def test_a_signal_during_the_kernels_wait_is_handled_and_the_step_answered(
    fixture_fmu, write_system
) -> None:
    """A signal while a step is waited for (in the kernel for 20 ms, then in Python) has its
    handler run during the wait, and the step's answer is still read (the child is stopped
    while the signal comes). The kernel's own part is covered with a stand-in below."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    handled: list[float] = []
    previous = signal.signal(
        signal.SIGUSR1, lambda number, frame: handled.append(time.perf_counter())
    )
    try:
        with isolated(component, 30.0) as runner:
            assert runner.stepped_natively
            assert runner._link is not None  # the supervisor's end is the kernel's too
            u, y = runner.input_buffer("u"), runner.output_buffer("y")
            assert runner._process is not None
            pid = runner._process.pid
            os.kill(pid, signal.SIGSTOP)
            threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGUSR1)).start()
            threading.Timer(0.8, os.kill, (pid, signal.SIGCONT)).start()
            u[0] = 2.0
            started = time.perf_counter()
            runner.step(0.0, 0.01)
            assert time.perf_counter() - started >= 0.75
            assert len(handled) == 1
            assert handled[0] - started < 0.7  # while the step was still waited for
            assert y[0] == 6.0
            for k in range(1, 30):  # and the kernel's ends go on
                u[0] = float(k)
                runner.step(k * 0.01, 0.01)
                assert y[0] == 3.0 * k
    finally:
        signal.signal(signal.SIGUSR1, previous)


def test_a_stop_signal_during_the_kernels_wait_leaves_the_step_to_be_answered(
    fixture_fmu, write_system
) -> None:
    """A stop request (Ctrl-C) while a step's answer is waited for (the kernel's 20 ms, then
    Python's wait) is raised with the step counted as sent: ending the model then reads that
    answer first and the child ends by itself, not killed after the grace period."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    runner = unstarted(component, 30.0)
    try:
        runner.instantiate()
        runner.setup(0.0, 1.0)
        assert runner.stepped_natively
        process = runner._process
        assert process is not None
        os.kill(process.pid, signal.SIGSTOP)
        threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
        threading.Timer(0.8, os.kill, (process.pid, signal.SIGCONT)).start()
        began = time.perf_counter()
        with pytest.raises(StopRequested), stop_on_signals():
            runner.step(0.0, 0.01)
        assert time.perf_counter() - began < 0.7  # raised while the child was stopped
        assert list(runner._pending) == [False]  # the step's answer is still to be read
    finally:
        started = time.perf_counter()
        runner.terminate()
    assert time.perf_counter() - started < 4.0  # TERMINATE_GRACE is 5 s
    assert process.wait() == 0


def test_a_stop_signal_while_the_command_pipe_is_full_stops_the_run(
    fixture_fmu, write_system, monkeypatch
) -> None:
    """A child that stops reading its commands (a hostile model can) leaves the pipe full and
    the supervisor's write blocked: a stop request still ends that write, as in Python, and
    nothing is left pending. (A watchdog kills the child after 5 s: a write that waited for
    ever would end there in a fault, not in the stop.) Ending the model then does not wait
    for ever to ask the child to terminate through the same full pipe (as it did, in Python
    too): after the grace period it kills the child."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    runner = unstarted(component, 30.0)
    try:
        runner.instantiate()
        runner.setup(0.0, 1.0)
        process = runner._process
        assert process is not None
        assert runner._link is not None
        os.kill(process.pid, signal.SIGSTOP)
        commands = runner._commands
        os.set_blocking(commands, False)
        with contextlib.suppress(BlockingIOError):
            while True:
                os.write(commands, bytes(4096))
        os.set_blocking(commands, True)
        threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
        watchdog = threading.Timer(5.0, os.kill, (process.pid, signal.SIGKILL))
        watchdog.start()
        began = time.perf_counter()
        with pytest.raises(StopRequested), stop_on_signals():
            runner.step(0.0, 0.01)
        watchdog.cancel()
        assert time.perf_counter() - began < 4.0
        assert not runner._pending  # the step was never written
    finally:
        monkeypatch.setattr(proxy, "TERMINATE_GRACE", 0.5)
        rescue = threading.Timer(10.0, os.kill, (process.pid, signal.SIGKILL))  # if it hangs
        rescue.start()
        ending = time.perf_counter()
        runner.terminate()
        rescue.cancel()
    assert time.perf_counter() - ending < 3.0
    assert process.wait() == -signal.SIGKILL


def test_a_child_hung_in_a_step_a_stop_interrupted_is_killed_after_one_grace(
    fixture_fmu, write_system, monkeypatch
) -> None:
    """Ctrl-C or SIGTERM while an isolated model hangs in its step: ending the model waits
    the grace period once for the step's answer, then kills the child. It waited a second
    grace for the child to exit (10 s in all: past a container runtime's 10 s before its
    SIGKILL, which then took the results with it)."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    runner = unstarted(component, 30.0)
    try:
        runner.instantiate()
        runner.setup(0.0, 1.0)
        process = runner._process
        assert process is not None
        os.kill(process.pid, signal.SIGSTOP)  # hung in its step, as a model that never returns
        threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
        with pytest.raises(StopRequested), stop_on_signals():
            runner.step(0.0, 0.01)
    finally:
        monkeypatch.setattr(proxy, "TERMINATE_GRACE", 2.0)
        ending = time.perf_counter()
        runner.terminate()
    assert time.perf_counter() - ending < 3.5  # one grace of 2 s, not two
    assert process.wait() == -signal.SIGKILL


def test_without_the_kernel_the_child_steps_in_python(
    fixture_fmu, write_system, monkeypatch
) -> None:
    monkeypatch.setenv("FMIONNX_NATIVE", "0")
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 2.0}")
    with isolated(component, 30.0) as runner:
        assert not runner.stepped_natively
        u, y = runner.input_buffer("u"), runner.output_buffer("y")
        for k in range(20):
            u[0] = float(k)
            runner.step(k * 0.01, 0.01)
            assert y[0] == 2.0 * k


# -- the supervisor's bookkeeping around the kernel's call ---------------------------------------


class _Link:
    """Stands in for the kernel's end (:class:`fmionnx.runtime.isolated.handover.Link`): each
    call does what its outcome says the kernel did -- write the command, read a reply's first
    byte -- then, maybe, something that interrupts (``then``), and returns the outcome's code."""

    def __init__(self, *outcomes: tuple[int, bool, bytes | None, Callable[[], None] | None]):
        self._outcomes = list(outcomes)
        self._sent = self._answered = 0
        self.tag = b"?"
        self.error = errno.EIO
        self.spins = 0
        self.calls = 0

    def prepare(self, sent: int, answered: int) -> None:
        self._sent, self._answered = sent, answered

    def call(self, *, spin: bool) -> int:
        code, written, tag, then = self._outcomes.pop(0)
        self.calls += 1
        if written:
            self._sent += 1
        if tag is not None:
            self._answered += 1
            self.tag = tag
        if then is not None:
            then()
        return code

    def written(self, sent: int) -> bool:
        return self._sent != sent

    def answered(self, answered: int) -> bool:
        return self._answered != answered


class _Waited(Exception):  # noqa: N818 - a marker: the Python wait was entered
    pass


def _interrupt() -> None:
    raise KeyboardInterrupt


def _stop_signal() -> None:
    os.kill(os.getpid(), signal.SIGINT)


def _counts(runner: IsolatedRunner) -> tuple[int, int, int]:
    """Commands sent and replies read in this run, and replies pending."""
    return (runner._sent - KEPT, runner._answered - KEPT, len(runner._pending))


def _bookkept(fixture_fmu, write_system, link: _Link) -> IsolatedRunner:
    """An isolated runner (no process) whose steps go through ``link``; its Python wait, death
    and hang handling raise :class:`_Waited` and record which was entered."""
    runner = unstarted(lone_component(fixture_fmu, write_system, "Gain"))
    runner._link = link  # type: ignore[assignment]
    runner._sent = runner._answered = KEPT  # a kept child's counters go on from its last run
    entered: list[str] = []
    runner.entered = entered  # type: ignore[attr-defined]

    def waited(name: str) -> Callable[..., object]:
        def enter(*args: object, **kwargs: object) -> object:
            entered.append(name)
            raise _Waited(name)

        return enter

    runner._await = waited("await")  # type: ignore[method-assign]
    runner._died = waited("died")  # type: ignore[method-assign]
    runner._kill_hung = waited("kill_hung")  # type: ignore[method-assign]
    return runner


OK, ERROR = b"k", b"e"
#: Commands and replies a kept child had exchanged before (its counters do not start at 0).
KEPT = 7


@pytest.mark.parametrize(
    ("outcomes", "entered", "counts", "tag"),
    [
        ([(k.LINK_REPLY, True, OK, None)], [], (1, 1, 0), None),
        ([(k.LINK_REPLY, True, ERROR, None)], ["await"], (1, 0, 1), ERROR),
        ([(k.LINK_INTERRUPTED, True, None, None)], ["await"], (1, 0, 1), None),
        ([(k.LINK_TIMEOUT, True, None, None)], ["kill_hung"], (1, 0, 1), None),
        ([(k.LINK_CLOSED, True, None, None)], ["died"], (1, 0, 1), None),
        ([(k.LINK_BROKEN, False, None, None)], ["died"], (0, 0, 0), None),
        (  # a signal interrupted the write: written again
            [(k.LINK_INTERRUPTED, False, None, None), (k.LINK_REPLY, True, OK, None)],
            [],
            (1, 1, 0),
            None,
        ),
    ],
    ids=["ok", "error-reply", "long-step", "timeout", "closed", "broken", "write-again"],
)
def test_the_supervisor_settles_what_the_kernel_did(
    fixture_fmu, write_system, outcomes, entered, counts, tag
) -> None:
    link = _Link(*outcomes)
    runner = _bookkept(fixture_fmu, write_system, link)
    if entered:
        with pytest.raises(_Waited):
            runner.step(0.0, 0.01)
    else:
        runner.step(0.0, 0.01)
    assert runner.entered == entered  # type: ignore[attr-defined]
    assert _counts(runner) == counts
    assert runner._tag == tag
    assert link.calls == len(outcomes)


@pytest.mark.parametrize(
    ("written", "tag", "counts"),
    [
        (True, OK, (1, 1, 0)),
        (True, None, (1, 0, 1)),
        (True, ERROR, (1, 0, 1)),
        (False, None, (0, 0, 0)),
    ],
    ids=["answered", "unanswered", "error-read", "unwritten"],
)
def test_an_interrupt_right_after_the_kernels_call_leaves_whole_counts(
    fixture_fmu, write_system, written: bool, tag: bytes | None, counts: tuple[int, int, int]
) -> None:
    """A KeyboardInterrupt (Python's own handler) raised as the call returns: the counts
    still say what the kernel wrote and read, so ending the model reads exactly the rest."""
    code = k.LINK_REPLY if tag is not None else k.LINK_INTERRUPTED
    runner = _bookkept(fixture_fmu, write_system, _Link((code, written, tag, _interrupt)))
    with pytest.raises(KeyboardInterrupt):
        runner.step(0.0, 0.01)
    assert _counts(runner) == counts
    assert runner._tag == (tag if tag == ERROR else None)
    assert runner.entered == []  # type: ignore[attr-defined]


def test_a_stop_held_by_the_shield_is_raised_once_the_counts_are_whole(
    fixture_fmu, write_system
) -> None:
    """A stop signal during the kernel's wait (``fmionnx run``'s handler): held while the
    counts are settled, raised before the Python wait begins."""
    link = _Link((k.LINK_INTERRUPTED, True, None, _stop_signal))
    runner = _bookkept(fixture_fmu, write_system, link)
    with pytest.raises(StopRequested), stop_on_signals():
        runner.step(0.0, 0.01)
    assert _counts(runner) == (1, 0, 1)
    assert runner.entered == []  # type: ignore[attr-defined]
