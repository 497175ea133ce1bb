"""Isolated children forked by the zygote (``fmionnx/runtime/isolated/zygote.py``).

A process's first isolated component starts a zygote that imports what a child needs once;
every child after that is a fork of it. Whatever happens to the zygote, a run must neither
change its results nor depend on it: a child started as a new interpreter is the fallback.
The models are the real test FMUs, the children real processes.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from fmionnx.core.errors import RunError
from fmionnx.runtime.isolated import launcher
from fmionnx.runtime.isolated.launcher import ForkedChild, SpawnedChild, Zygote, ZygoteError
from fmionnx.runtime.isolated.proxy import IsolatedRunner
from fmionnx.runtime.result import RunStatus
from tests.backends.isolated_runner import (
    assert_completed_alike,
    isolated,
    isolated_chain,
    lone_component,
    unstarted,
)

HANG = 6
SEGFAULT = 3


def _zygote_pid() -> int:
    zygote = launcher._zygote.get()
    assert zygote is not None
    return zygote._process.pid


@pytest.fixture
def fresh_zygote() -> Iterator[None]:
    """Each test starts with no zygote in this process and leaves none behind."""

    def drop() -> None:
        zygote = launcher._zygote.clear()
        if zygote is not None:
            zygote.close()
        launcher._no_zygote.clear()

    drop()
    yield
    drop()


def _gain_steps(runner: IsolatedRunner, gain: float, steps: int = 5) -> None:
    u, y = runner.input_buffer("u"), runner.output_buffer("y")
    for k in range(steps):
        u[0] = float(k)
        runner.step(k * 0.01, 0.01)
        assert y[0] == gain * k


def test_children_are_forked_by_one_zygote_that_outlives_them(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 2.0}")
    with isolated(component) as first, isolated(component) as second:
        assert isinstance(first._process, ForkedChild)
        assert isinstance(second._process, ForkedChild)
        zygote = _zygote_pid()
        for runner in (first, second):  # the zygote is the children's parent
            status = Path(f"/proc/{runner._process.pid}/status").read_text()
            assert f"PPid:\t{zygote}\n" in status
            _gain_steps(runner, 2.0)
    with isolated(component) as third:
        assert _zygote_pid() == zygote
        _gain_steps(third, 2.0)


def test_a_forked_child_holds_only_its_own_descriptors(
    fixture_fmu, write_system, fresh_zygote, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Not the zygote's socket, nor a sibling's pipes: a model could otherwise forge another
    child's exit status or keep the zygote's socket open after the supervisor is gone."""
    component = lone_component(fixture_fmu, write_system, "Gain")
    monkeypatch.chdir(tmp_path)  # the child works in the supervisor's folder of the moment
    with isolated(component), isolated(component) as runner:  # a sibling alive meanwhile
        pid = runner._process.pid
        assert Path(f"/proc/{pid}/cwd").resolve() == tmp_path.resolve()
        kinds = []
        for entry in Path(f"/proc/{pid}/fd").iterdir():
            with contextlib.suppress(OSError):  # closed while it was listed
                kinds.append(stat.S_IFMT(entry.stat().st_mode))
        assert stat.S_IFSOCK not in kinds
        pipes = sum(kind == stat.S_IFIFO for kind in kinds)
        assert pipes <= 2  # its command and reply pipes (stdio may be pipes too under pytest)


def test_a_crash_in_a_forked_child_is_reported_with_its_signal(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    component = lone_component(
        fixture_fmu, write_system, "Faulty", f", parameters: {{mode: {SEGFAULT}, failAt: 0.02}}"
    )
    with isolated(component) as runner:
        assert isinstance(runner._process, ForkedChild)
        runner.step(0.0, 0.01)
        runner.step(0.01, 0.01)
        with pytest.raises(RunError, match="crashed with SIGSEGV"):
            runner.step(0.02, 0.01)


def test_a_hung_forked_child_is_killed_through_its_pidfd(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    component = lone_component(
        fixture_fmu, write_system, "Faulty", f", parameters: {{mode: {HANG}, failAt: 0.01}}"
    )
    with isolated(component, timeout=1.0) as runner:
        process = runner._process
        assert isinstance(process, ForkedChild)
        runner.step(0.0, 0.01)
        with pytest.raises(RunError, match="did not return within 1 s"):
            runner.step(0.01, 0.01)
        assert process.returncode == -signal.SIGKILL  # reported by the zygote, its parent


def test_a_killed_zygote_takes_its_children_and_the_next_child_gets_a_new_one(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 3.0}")
    with isolated(component) as runner:
        zygote = _zygote_pid()
        os.kill(zygote, signal.SIGKILL)
        with pytest.raises(RunError, match="crashed with SIGKILL"):
            _gain_steps(runner, 3.0, steps=1000)  # its child died with it (PDEATHSIG)
    with isolated(component) as runner:  # the dead zygote is noticed, a new one forks
        _gain_steps(runner, 3.0)
        assert isinstance(runner._process, ForkedChild)
        assert _zygote_pid() != zygote


def test_without_a_zygote_children_start_as_new_interpreters(
    fixture_fmu, write_system, fresh_zygote, monkeypatch: pytest.MonkeyPatch
) -> None:
    starts = []

    def failing() -> Zygote:
        starts.append(1)
        raise ZygoteError("did not get ready")

    monkeypatch.setattr(launcher, "Zygote", failing)
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 4.0}")
    for _ in range(2):
        with isolated(component) as runner:
            assert isinstance(runner._process, SpawnedChild)
            _gain_steps(runner, 4.0)
    assert starts == [1]  # one failed start: the process does not try at every child


def test_a_zygote_that_does_not_answer_is_replaced(
    fixture_fmu, write_system, fresh_zygote, monkeypatch: pytest.MonkeyPatch
) -> None:
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 5.0}")
    with isolated(component):
        pass
    deaf = _zygote_pid()
    os.kill(deaf, signal.SIGSTOP)  # alive, but deaf
    monkeypatch.setattr(launcher, "ZYGOTE_ANSWER_TIMEOUT", 0.5)
    monkeypatch.setattr(launcher, "ZYGOTE_EXIT_TIMEOUT", 0.5)
    try:
        with isolated(component) as runner:
            assert isinstance(runner._process, ForkedChild)
            _gain_steps(runner, 5.0)
            assert _zygote_pid() != deaf
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(deaf, signal.SIGCONT)
    assert not Path(f"/proc/{deaf}").exists()  # the deaf one was killed and reaped


def test_when_zygotes_keep_failing_a_child_starts_as_a_new_interpreter(
    fixture_fmu, write_system, fresh_zygote, monkeypatch: pytest.MonkeyPatch
) -> None:
    def deaf(self: Zygote, *args: object) -> ForkedChild:
        raise ZygoteError("did not answer")

    monkeypatch.setattr(Zygote, "launch", deaf)
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 6.0}")
    with isolated(component) as runner:
        assert isinstance(runner._process, SpawnedChild)
        _gain_steps(runner, 6.0)


def test_results_are_the_same_with_and_without_the_zygote(
    fixture_fmu, write_system, fresh_zygote, monkeypatch: pytest.MonkeyPatch
) -> None:
    system, everything = isolated_chain(fixture_fmu, write_system)
    forked = system.run(options=everything)
    assert forked.status is RunStatus.COMPLETED
    monkeypatch.setattr(launcher, "zygote_wanted", lambda: False)
    assert_completed_alike(forked, system.run(options=everything))


def test_the_zygote_ends_when_its_supervisor_closes_the_socket(fresh_zygote) -> None:
    zygote = Zygote()
    zygote._socket.shutdown(socket.SHUT_RDWR)
    assert zygote._process.wait(30) == 0
    zygote.close()


PRINT = 11


def test_what_an_isolated_model_printed_reaches_the_output_when_its_child_ends(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    """A forked child keeps the run's standard output (not closed with the zygote's other
    descriptors), and what a model printed there survives the child's ``os._exit`` (which
    skips a normal exit's flush; the child flushes Python's and C's streams first)."""
    system = write_system(
        f"""
fmionnx: 1
name: talker
run: {{stop: 0.05, step: 0.01}}
components:
  m: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {PRINT}, failAt: 0.0}}}}
"""
    )
    code = "import sys; from fmionnx.cli import main; sys.argv[0] = 'fmionnx'; main()"
    done = subprocess.run(
        [sys.executable, "-c", code, "run", str(system), "--out", str(tmp_path / "out"),
         "--isolate", "fmus", "--quiet"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    printed = [line for line in done.stdout.splitlines() if line.startswith("Faulty: a line")]
    assert len(printed) == 5, done.stdout


def test_a_supervisor_whose_working_folder_was_removed_starts_a_new_interpreter(
    fixture_fmu, write_system, fresh_zygote, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The zygote would have no folder to put the child in: the child starts as a new
    interpreter, inheriting the removed folder as it did before the zygote (where the
    model's load fails: a fault of the component saying why, not a crash)."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 7.0}")
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    runner = unstarted(component)
    try:
        runner.instantiate()
        assert isinstance(runner._process, SpawnedChild)
        with pytest.raises(RunError, match="working folder was removed"):
            runner.setup(0.0, 1.0)
    finally:
        runner.terminate()


def test_no_zygote_where_the_kernel_has_no_pidfds(monkeypatch: pytest.MonkeyPatch) -> None:
    """Python may offer ``os.pidfd_open`` on a kernel older than 5.3: one is opened to know."""

    def missing(pid: int) -> int:
        raise OSError(38, "Function not implemented")

    launcher.zygote_wanted.cache_clear()
    try:
        assert launcher.zygote_wanted()
        launcher.zygote_wanted.cache_clear()
        monkeypatch.setattr(os, "pidfd_open", missing)
        assert not launcher.zygote_wanted()
    finally:
        launcher.zygote_wanted.cache_clear()


def test_a_child_killed_between_two_steps_is_a_fault_of_the_next_step(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    """The next step's command meets a closed pipe: a fault saying how the child ended, not
    a ``BrokenPipeError`` (seen when the zygote, and with it its child, was killed)."""
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 2.0}")
    with isolated(component) as runner:
        _gain_steps(runner, 2.0)
        process = runner._process
        assert process is not None
        os.kill(process.pid, signal.SIGKILL)
        assert process.wait(30) == -signal.SIGKILL
        with pytest.raises(RunError, match="crashed with SIGKILL"):
            runner.step(0.05, 0.01)


def test_a_prestarted_zygote_imports_meanwhile_and_forks_the_first_child(
    fixture_fmu, write_system, fresh_zygote
) -> None:
    """``prestart`` returns at once (the zygote's imports go on in its process); the first
    child waits for them and is forked by it."""
    launcher.prestart()
    started = launcher._zygote.get()
    assert started is not None
    assert not started._ready  # did not wait for the zygote's imports
    component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 7.0}")
    with isolated(component) as runner:
        assert isinstance(runner._process, ForkedChild)
        _gain_steps(runner, 7.0)
    assert launcher._zygote.get() is started  # the same one: prestart made it


def test_a_prestarted_zygote_that_never_gets_ready_is_given_up(
    fixture_fmu, write_system, fresh_zygote, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(launcher, "ZYGOTE_START_TIMEOUT", 0.5)
    monkeypatch.setattr(launcher, "ZYGOTE_EXIT_TIMEOUT", 0.5)
    launcher.prestart()
    started = launcher._zygote.get()
    assert started is not None
    os.kill(started._process.pid, signal.SIGSTOP)  # it will not say ready in time
    try:
        component = lone_component(fixture_fmu, write_system, "Gain", ", parameters: {k: 8.0}")
        for _ in range(2):
            with isolated(component) as runner:
                assert isinstance(runner._process, SpawnedChild)
                _gain_steps(runner, 8.0)
        assert launcher._zygote.get() is None  # not tried again for the second child
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(started._process.pid, signal.SIGCONT)
