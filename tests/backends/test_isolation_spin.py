"""The hybrid wait of isolated components: spin on a counter, then block on the pipe.

Each side of an isolated model's pipes stores how many messages it has written in the shared
control block; the other side spins on that counter for a bounded time before it blocks on its
pipe as it always did (``fmionnx.runtime.isolated.channel.Spinner``). The counters are only a
hint: a model can write anything into the shared block, so a forged counter must at worst make
the supervisor fall back to its blocking wait, with the step timeout as before. The forging
here is done by a thread of the test writing the very memory the child writes (one shared
mapping), while a real child process steps a real FMU.
"""

from __future__ import annotations

import ctypes
import os
import random
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core.errors import RunError
from fmionnx.runtime.isolated import channel, launcher, proxy
from fmionnx.runtime.isolated.proxy import IsolatedRunner
from fmionnx.runtime.parallel import Job, Lane
from fmionnx.runtime.result import RunOptions, RunStatus
from tests.backends.isolated_runner import (
    assert_completed_alike,
    isolated,
    isolated_chain,
    lone_component,
)

HANG = 6


# -- the spinner alone -----------------------------------------------------------------------


def test_the_spin_ends_as_soon_as_the_counter_moves() -> None:
    counter = ctypes.c_uint32(7)
    spinner = channel.Spinner(10_000_000_000)  # 10 s: only the counter can end it quickly
    threading.Timer(0.01, lambda: setattr(counter, "value", 8)).start()
    started = time.perf_counter()
    assert spinner.wait(counter, 7)
    assert time.perf_counter() - started < 5.0
    assert (spinner.spins, spinner.hits) == (1, 1)


def test_a_missed_spin_backs_off_and_a_hit_resets_it() -> None:
    counter = ctypes.c_uint32(0)
    spinner = channel.Spinner(1_000_000, max_backoff=2)  # 1 ms
    assert not spinner.wait(counter, 0)  # miss: the next wait skips its spin
    assert not spinner.wait(counter, 0)
    assert spinner.spins == 1
    assert not spinner.wait(counter, 0)  # second miss: three skipped (2**2 - 1) ...
    assert [spinner.wait(counter, 0) for _ in range(3)] == [False] * 3
    assert spinner.spins == 2
    counter.value = 1  # ... then it spins again and a hit ends the backoff
    assert spinner.wait(counter, 0)
    assert spinner.wait(counter, 0)
    assert (spinner.spins, spinner.hits) == (4, 2)


def test_a_spinner_without_budget_never_spins() -> None:
    spinner = channel.Spinner(0)
    assert not spinner.wait(ctypes.c_uint32(1), 0)
    assert spinner.spins == 0


# -- a real child process ----------------------------------------------------------------------


def _child_pid(runner: IsolatedRunner) -> int:
    assert runner._process is not None
    return runner._process.pid


@pytest.mark.parametrize("timeout", [30.0, None])
def test_a_step_slower_than_the_spin_still_answers(fixture_fmu, write_system, timeout) -> None:
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    with isolated(component, timeout) as runner:
        u, y = runner.input_buffer("u"), runner.output_buffer("y")
        u[0] = 1.0
        runner.step(0.0, 0.01)
        assert y[0] == 3.0
        pid = _child_pid(runner)
        late = proxy.SPIN_NS * 20e-9  # the child answers 20x later than the spin lasts
        os.kill(pid, signal.SIGSTOP)
        # Timed from before the timer starts: this thread may lose its core between the two
        # (a loaded machine), and the answer is only sure to come `late` after the timer's start.
        started = time.perf_counter()
        threading.Timer(late, os.kill, (pid, signal.SIGCONT)).start()
        u[0] = 2.0
        runner.step(0.01, 0.01)
        assert time.perf_counter() - started >= late  # the answer came after the spin ran out
        assert y[0] == 6.0
        for k in range(2, 50):  # and the waits go on answering, spinning again or not
            u[0] = float(k)
            runner.step(k * 0.01, 0.01)
            assert y[0] == 3.0 * k


@contextmanager
def _forger(runner: IsolatedRunner) -> Iterator[None]:
    """A thread writing random values into the reply counter, as a hostile model could."""
    assert runner._control is not None
    counter = runner._control.replies
    stop = threading.Event()
    rng = random.Random(14)

    def forge() -> None:
        while not stop.is_set():
            counter.value = rng.getrandbits(32)
            time.sleep(0)

    thread = threading.Thread(target=forge, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def _steps_on(thread_kind: str, runner: IsolatedRunner) -> None:
    """Twenty steps of ``runner`` on a plain thread or on a parallel schedule's lane."""

    def steps() -> None:
        for k in range(20):
            runner.step(k * 0.01, 0.01)

    if thread_kind == "thread":
        thread = threading.Thread(target=steps)
        thread.start()
        thread.join()
        return
    lane = Lane("gain")
    lane.submit(Job(None, lambda t, h: steps(), 0.0, 0.01, 0, 0))
    _, outcome = lane.wait()
    lane.close()
    assert outcome is None


@pytest.mark.parametrize(("thread_kind", "spins"), [("thread", True), ("lane", False)])
def test_the_supervisor_spins_on_any_thread_but_a_lane(
    fixture_fmu, write_system, thread_kind: str, spins: bool
) -> None:
    """A sweep runs its cases on a Dask worker's task thread: its waits spin as the main
    thread's do (they did not, and a sweep's case took 12 % longer than in a plain loop); a
    lane leaves the GIL to the loop's thread."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 2.0}")
    with isolated(component, 30.0) as runner:
        _steps_on(thread_kind, runner)
        assert (runner.waits_spun > 0) is spins


def test_a_forged_reply_counter_cannot_make_the_supervisor_read_early(
    fixture_fmu, write_system
) -> None:
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 0.5}")
    with isolated(component, 30.0) as runner, _forger(runner):
        u, y = runner.input_buffer("u"), runner.output_buffer("y")
        pid = _child_pid(runner)
        for k in range(200):
            if k % 50 == 0:  # now and then the child is late, while the counter says ready
                os.kill(pid, signal.SIGSTOP)
                threading.Timer(0.02, os.kill, (pid, signal.SIGCONT)).start()
            u[0] = float(k)
            runner.step(k * 0.01, 0.01)
            assert y[0] == 0.5 * k


def test_a_forged_reply_counter_cannot_hide_a_hang(fixture_fmu, write_system) -> None:
    component = lone_component(
        fixture_fmu, write_system, "Faulty", f", parameters: {{mode: {HANG}, failAt: 0.02}}"
    )
    with isolated(component, 1.0) as runner, _forger(runner):
        runner.step(0.0, 0.01)
        runner.step(0.01, 0.01)
        started = time.perf_counter()
        with pytest.raises(RunError, match="did not return within 1 s"):
            runner.step(0.02, 0.01)  # the model hangs from failAt on
        assert time.perf_counter() - started < 30.0
        assert runner._process is None or runner._process.poll() is not None


def test_spinning_leaves_a_multi_fmu_system_byte_identical(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    system, everything = isolated_chain(fixture_fmu, write_system)
    spinning = system.run(options=everything)
    monkeypatch.setattr(proxy, "SPIN_NS", 0)  # the supervisor's waits as before the counters
    blocking = system.run(options=everything)
    plain = system.run(isolate="none")
    for result in (spinning, blocking):
        assert_completed_alike(plain, result)


@pytest.mark.parametrize(
    ("spin", "cores", "flag"),
    [(True, 2, []), (False, 2, ["--no-spin"]), (True, 1, ["--no-spin"])],
    ids=["spins", "one-core-each", "confined-to-one-core"],
)
def test_a_child_is_told_not_to_spin_once_cases_have_one_core_each(
    fixture_fmu,
    write_system,
    monkeypatch: pytest.MonkeyPatch,
    spin: bool,
    cores: int,
    flag: list[str],
) -> None:
    seen: list[list[str]] = []
    launch = launcher.launch
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(cores)))

    def recording(fds: tuple[int, int, int], argv: list[str], env: dict[str, str]) -> object:
        seen.append(list(argv))
        return launch(fds, argv, env)

    monkeypatch.setattr(launcher, "launch", recording)
    monkeypatch.setattr(proxy, "_children_spin", [spin])
    system = fmionnx.load(
        write_system(
            f"""
fmionnx: 1
name: one
run: {{stop: 0.1, step: 0.01}}
components:
  g: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 2.0}}}}
"""
        )
    )
    result = system.run(options=RunOptions(isolate=frozenset({"g"})))
    assert result.status is RunStatus.COMPLETED
    assert seen == [flag]
