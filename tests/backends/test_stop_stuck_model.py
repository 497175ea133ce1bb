"""A stop signal ends a run whose model hangs in fmionnx's own process (``--isolate none``).

Python runs a signal's handler between bytecodes of the main thread, and a model stuck in
its step keeps the main thread in native code: Ctrl-C and SIGTERM did nothing until the step
timeout (60 s by default) abandoned the run, which then ended as a fault with exit status 1,
the stop lost (a bug hunt). The watchdog now reads the signal from the wake-up fd and
abandons the run as interrupted a second later (:mod:`fmionnx.runtime.stopnotice`).
"""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import pytest

import fmionnx
from fmionnx.results.csvfile import read_csv
from fmionnx.runtime.master import Master
from fmionnx.runtime.stopnotice import ACTED_GRACE, STOP_GRACE, StopNotice
from fmionnx.runtime.stopping import StopRequested, stop_on_signals, stops_held
from fmionnx.runtime.watchdog import Marker, Watchdog
from tests.backends.test_isolation import HANG, SYSTEM, _cli, _finish


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stop_ends_a_run_stuck_in_a_model_of_this_process(
    fixture_fmu, write_system, tmp_path: Path, stop: signal.Signals
) -> None:
    system = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=f"{fixture_fmu('Gain')}, interface: me", mode=HANG,
            stop=1.0, step=0.001, fail_at=0.6,
        )
    )  # fmt: skip
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--isolate", "none", "--checkpoint-every", "0"]
    args += ["--step-timeout", "120"]  # far beyond the test's wait: only the stop can end it
    process = _cli(args, tmp)
    deadline = time.monotonic() + 60
    while not (out / "run.json").exists() and process.poll() is None:
        assert time.monotonic() < deadline, "no checkpoint came"
        time.sleep(0.05)  # the checkpoint at step 500 of 600: the hang is a moment away
    time.sleep(0.5)
    process.send_signal(stop)
    signalled = time.monotonic()
    code, output = _finish(process, timeout=60)
    assert code == 128 + stop, output
    assert time.monotonic() - signalled < 30  # not the step timeout's 120 s
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert (info["status"], info["interrupted_by"]) == ("interrupted", stop.name)
    warning = (
        f"component `bad` did not return from its step after {stop.name}: it runs in "
        "fmionnx's own process, so the run was abandoned"
    )
    assert [w for w in info["warnings"] if w.startswith(warning)], info["warnings"]
    assert f"interrupted by {stop.name} at t=0.6 s" in output
    assert "Traceback" not in output
    assert read_csv(out / "results.csv")["time"][-1] == pytest.approx(0.6)  # every step kept


class _Notice(StopNotice):
    """A stop signal pending from ``at`` on (no wake-up fd: the watchdog is driven by hand)."""

    def __init__(self, at: float | None) -> None:
        super().__init__()
        self.at = at

    def poll(self, now: float) -> int | None:
        if self.at is not None and now >= self.at and self.signum is None:
            self.signum, self.pending_since, self.first_at = int(signal.SIGINT), now, now
        return self.signum


def _watchdog(work: object, notice: StopNotice) -> tuple[Watchdog, Marker]:
    marker = Marker()
    marker.work, marker.t = work, 0.5
    watchdog = Watchdog(60.0, marker, [work], lambda *_: None)
    watchdog.notice = notice
    return watchdog, marker


def test_the_watchdog_fires_once_the_same_call_kept_a_stop_pending() -> None:
    work = object()
    watchdog, _ = _watchdog(work, _Notice(at=10.0))
    assert not watchdog.look(9.0)  # the call is seen
    assert not watchdog.look(10.0)  # the stop is seen
    assert not watchdog.look(10.0 + STOP_GRACE * 0.9)
    assert watchdog.look(10.0 + STOP_GRACE)


def test_a_stop_acted_on_fires_when_the_loop_still_waits_for_the_call_later() -> None:
    """The second review: with the parallel schedule the loop waits for a hung lane's step
    in Python, so the handler runs and the stop is not pending; it waited for the step
    timeout and ended as a fault. It is abandoned as interrupted after the longer grace."""
    work = object()
    notice = _Notice(at=10.0)
    watchdog, _ = _watchdog(work, notice)
    assert not watchdog.look(10.0)
    notice.pending_since = None  # the handler ran: the loop waits for the lane
    assert not watchdog.look(10.0 + STOP_GRACE)
    assert not watchdog.look(10.0 + ACTED_GRACE * 0.9)
    assert watchdog.look(10.0 + ACTED_GRACE)


def test_a_declined_stop_leaves_the_watchdog_watching() -> None:
    """When the loop's thread ends the run itself (the handler declines), the watchdog must
    go on timing: its termination is still timed."""
    from fmionnx.runtime.watchdog import _watcher

    work = object()
    marker = Marker()
    marker.work, marker.t = work, 0.5
    watchdog = Watchdog(60.0, marker, [work], lambda *_: False)
    watchdog.notice = _Notice(at=10.0)
    assert not watchdog.look(10.0)
    assert watchdog.look(10.0 + STOP_GRACE)
    try:
        watchdog.fire()
        assert watchdog in _watcher()._active
    finally:
        watchdog.stop()
    assert watchdog not in _watcher()._active


def test_no_stop_fires_while_the_run_ends_however_long_its_models_take() -> None:
    """After the last step (models terminating, results written) a stop is a late one that
    the run only reports: the watchdog must not abandon it as interrupted."""
    work = object()
    watchdog, _ = _watchdog(work, _Notice(at=10.0))
    with stops_held():
        assert not watchdog.look(10.0)
        assert not watchdog.look(10.0 + 5 * STOP_GRACE)
    assert watchdog.look(10.0 + 6 * STOP_GRACE)


def test_an_unwatched_call_is_left_to_its_own_process() -> None:
    watchdog, marker = _watchdog(object(), _Notice(at=10.0))
    marker.work = object()  # an isolated component's step: its proxy stops it
    assert not watchdog.look(10.0)
    assert not watchdog.look(10.0 + 5 * STOP_GRACE)


def test_a_stop_is_pending_only_until_the_main_thread_runs_its_handler() -> None:
    """The review of this change: once the handler ran (the stop raised, or held by a shield)
    the main thread is not stuck, whatever it waits for next (a lane's step after Ctrl-C)."""
    with stop_on_signals(), StopNotice() as notice:
        os.write(notice._write, b"\x11\x02")  # as the C handler writes: SIGCHLD, SIGINT
        assert notice.poll(1.0) == signal.SIGINT  # SIGCHLD (17): not a stop
        assert notice.pending_since == 1.0
        assert notice.poll(1.5) == signal.SIGINT
        assert notice.pending_since == 1.0  # pending since it came
        with pytest.raises(StopRequested):
            signal.raise_signal(signal.SIGINT)  # the handler runs: the main thread acted
        assert notice.poll(2.0) == signal.SIGINT  # the first stop that came
        assert notice.pending_since is None  # but no longer pending
        assert notice.poll(2.5) == signal.SIGINT
        assert notice.pending_since is None  # its byte, read late, is the one acted on


def test_a_program_handling_its_own_signals_gets_no_notice() -> None:
    """The review of this change: ``fmionnx.run`` in a notebook or a service (no
    ``stop_on_signals``: the program's own Ctrl-C and SIGTERM handling) was killed by a stop
    during a call of more than a second; it keeps its own handling, and a program's earlier
    wake-up fd stays in place."""
    read, write = os.pipe()
    os.set_blocking(write, False)
    previous = signal.set_wakeup_fd(write)
    try:
        with StopNotice() as notice:
            assert signal.set_wakeup_fd(write) == write  # not replaced
            assert notice.poll(1.0) is None
    finally:
        signal.set_wakeup_fd(previous)
        os.close(read)
        os.close(write)


def test_the_notice_passes_every_byte_on_to_the_earlier_wakeup_fd_and_restores_it() -> None:
    read, write = os.pipe()
    os.set_blocking(read, False)
    os.set_blocking(write, False)
    previous = signal.set_wakeup_fd(write)
    try:
        with stop_on_signals(), StopNotice() as notice:
            assert signal.set_wakeup_fd(notice._write) == notice._write  # its own pipe
            os.write(notice._write, b"\x11\x02")
            assert notice.poll(1.0) == signal.SIGINT
        assert signal.set_wakeup_fd(write) == write  # restored
        assert os.read(read, 16) == b"\x11\x02"
    finally:
        signal.set_wakeup_fd(previous)
        os.close(read)
        os.close(write)


def test_an_abandon_for_a_stop_declines_once_the_loop_ends_the_run(
    fixture_fmu, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The review of this change: a call that returns just after the grace raised the stop
    on the loop's thread, which then terminated the models while the watchdog abandoned the
    run and terminated them too. Whoever comes first ends it; a stop's abandon declines."""
    from fmionnx.runtime.result import RunOptions
    from fmionnx.runtime.watchdog import Phase

    system = fmionnx.load(fixture_fmu("Gain")).compiled
    master = Master(system, RunOptions(step_timeout=60.0))
    master.run()
    assert master._ends == "loop"  # the loop's thread ended it
    exits: list[int] = []

    def no_exit(code: int) -> None:  # a failing decline must fail this test, not end pytest
        exits.append(code)
        raise SystemExit(code)

    monkeypatch.setattr(os, "_exit", no_exit)
    stuck = Phase("Gain", "its termination")
    master._marker.work, master._marker.t = stuck, 0.0
    assert master._abandon(stuck, 0.0, stop=int(signal.SIGINT)) is False
    assert exits == []
