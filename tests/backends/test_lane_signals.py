"""A stop signal (Ctrl-C, SIGTERM, SIGHUP) can land between any two statements of the loop's
thread. The hand-over of a step to a worker lane is shielded: the signal is raised once the
lane's state is whole, so the loop never waits for ever for a step that was never queued or
whose outcome was already taken (seen as a run that did not end after SIGTERM, 2 in 30)."""

from __future__ import annotations

import os
import signal
import threading
from typing import Any

import pytest

from fmionnx.runtime.parallel import Job, Lane
from fmionnx.runtime.stopping import StopRequested, shield_begin, shield_end, stop_on_signals


def _job(ran: list[float]) -> Job:
    return Job(work=None, step=lambda t, h: ran.append(t), t=0.5, h=0.1, n=5, index=0)


def test_a_signal_inside_a_shield_is_raised_when_it_ends() -> None:
    with stop_on_signals():
        shield_begin()
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # Python runs the handler at one of these statements
            pass
        with pytest.raises(StopRequested) as stopped:
            shield_end()
    assert stopped.value.signal_name == "SIGTERM"


def test_a_shield_on_another_thread_neither_holds_nor_receives_the_signal() -> None:
    """Two runs in one program: a master on a worker thread opens shields too. The main
    thread's signal must stop the main thread now, and never surface in the other thread."""
    opened, release = threading.Event(), threading.Event()
    raised: list[BaseException] = []

    def other_run() -> None:
        shield_begin()
        opened.set()
        release.wait(10)
        try:
            shield_end()
        except BaseException as exc:  # what leaked into this thread, reported below
            raised.append(exc)

    thread = threading.Thread(target=other_run)
    thread.start()
    assert opened.wait(10)
    stopped = False
    try:
        with stop_on_signals():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):  # Python runs the handler at one of these statements
                pass
    except StopRequested:
        stopped = True
    finally:
        release.set()
        thread.join(10)
    assert stopped
    assert raised == []


class _SignallingQueue:
    """Delivers SIGTERM to this process just before the real ``put``: the moment where a
    signal cut the hand-over in half before it was shielded."""

    def __init__(self, real: Any) -> None:
        self.real = real

    def put(self, item: Any) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass
        self.real.put(item)

    def get(self) -> Any:
        return self.real.get()


def test_a_signal_during_submit_still_queues_the_step_the_lane_holds() -> None:
    ran: list[float] = []
    lane = Lane("x")
    lane.submit(_job(ran))  # starts the worker
    lane.wait()
    lane._inbox = _SignallingQueue(lane._inbox)  # type: ignore[assignment]
    job = _job(ran)
    with stop_on_signals(), pytest.raises(StopRequested):
        lane.submit(job)
    assert lane.job is job
    assert lane._finished.wait(10), "the step the lane holds was never queued"
    assert lane.wait() == (job, None)
    assert ran == [0.5, 0.5]
    lane._inbox = lane._inbox.real  # type: ignore[attr-defined]
    lane.close()


def test_a_wait_cut_short_can_be_waited_again_and_loses_no_outcome() -> None:
    release = threading.Event()
    lane = Lane("y")
    job = Job(work=None, step=lambda t, h: release.wait(), t=0.0, h=0.1, n=0, index=0)
    lane.submit(job)
    timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with stop_on_signals(), pytest.raises(StopRequested):
        lane.wait_finished()  # interrupted while the step runs
    release.set()
    assert lane.wait() == (job, None)
    assert lane.job is None
    lane.close()
