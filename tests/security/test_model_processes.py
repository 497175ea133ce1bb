"""A run ends with no process of its models left, and never waits for one.

The Probe test FMU (built from C) forks children that never end: plainly, leaving its process
group and handing over to orphaned grandchildren (``setsid``, double fork), or forking and
then crashing. Whatever it does, ``fmionnx run`` ends in time with no process of the model
left, whether the model ran in a process of its own (``--isolate``, the default for a system)
or under the guardian (the default for a lone FMU, whose wait for its child's pipe hung while
the model's children held the pipe open).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fmionnx.runtime import lifetime
from tests.security import probes

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="process rules of Linux")

#: Children the probe forks: enough that a sweep of one round would miss some.
CHILDREN = 50


@pytest.mark.parametrize("mode", [probes.FORK, probes.FORK_ESCAPE])
@pytest.mark.parametrize("isolation", ["fmus", "guardian", "default for a lone FMU"])
def test_no_process_of_a_model_outlives_its_run(
    fixture_fmu, tmp_path: Path, mode: int, isolation: str
) -> None:
    probe = {"p": f"{{mode: {mode}, count: {CHILDREN}}}"}
    system = probes.system(tmp_path, fixture_fmu("Probe"), probe)
    extra = [] if isolation.startswith("default") else ["--isolate", isolation]
    token = probes.Token()
    try:
        done = probes.run(system, tmp_path / "out", *extra, env=token.env)
        assert done.code == 0, done.output
        assert done.outcomes["p"] == CHILDREN  # the model did start them
        assert token.processes() == []
    finally:
        token.end_all()


@pytest.mark.parametrize("isolation", ["fmus", "guardian"])
def test_a_model_that_forks_then_crashes_is_a_fault_with_nothing_left(
    fixture_fmu, tmp_path: Path, isolation: str
) -> None:
    """Its children hold the pipes the run waits on: the run must not wait for them."""
    gain = fixture_fmu("Gain")
    probe = {"p": f"{{mode: {probes.FORK_THEN_CRASH}, count: {CHILDREN}, at: 0.02}}"}
    extra = f"  gain: {{kind: fmu, path: {gain}}}\n" if isolation == "fmus" else ""
    system = probes.system(tmp_path, fixture_fmu("Probe"), probe, extra=extra)
    token = probes.Token()
    try:
        done = probes.run(system, tmp_path / "out", "--isolate", isolation, env=token.env)
        assert done.code == 1, done.output
        assert "component `p` at t=0.02 s: the model crashed with SIGSEGV" in done.output
        assert token.processes() == []
    finally:
        token.end_all()


def test_models_run_in_this_process_leave_no_process_after_the_block(
    fixture_fmu, tmp_path: Path
) -> None:
    """``lifetime.models_here()``: for a run whose models run in fmionnx's own process (the
    Python API's in-process run here); it ends what they started."""
    probe = {"p": f"{{mode: {probes.FORK_ESCAPE}, count: {CHILDREN}}}"}
    system = probes.system(tmp_path, fixture_fmu("Probe"), probe)
    code = f"""
import fmionnx
from fmionnx.runtime import lifetime
with lifetime.models_here():
    result = fmionnx.load({str(system)!r}).run()
print(result["p.y"][-1])
"""
    token = probes.Token()
    try:
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=False,
            timeout=probes.RUN_TIMEOUT, env=dict(os.environ, **token.env),
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        assert float(done.stdout) == CHILDREN
        assert token.processes() == []
    finally:
        token.end_all()


def test_ending_descendants_ends_orphans_and_their_children(tmp_path: Path) -> None:
    """The mechanism itself, in a process of its own: a subreaper that ends its descendants
    finds the grandchildren an exited child left, in their own session."""
    ready = tmp_path / "ready"
    code = f"""
import os, sys, time
from pathlib import Path
from fmionnx.runtime import lifetime
lifetime.set_subreaper(True)
for _ in range(5):
    if os.fork() == 0:
        os.setsid()
        if os.fork() != 0:
            os._exit(0)  # the grandchild is orphaned at once
        while True:
            time.sleep(1)
time.sleep(0.5)
print(sorted(c.pid for c in lifetime.children(os.getpid())), flush=True)
Path({str(ready)!r}).write_text("")
print(lifetime.end_descendants(), lifetime.children(os.getpid()), flush=True)
"""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    adopted, ended = done.stdout.splitlines()
    assert len(eval(adopted)) >= 5  # the five grandchildren, adopted (and reaped children)
    assert ended.startswith("5 []")


def test_a_guarded_run_adopts_only_while_it_runs() -> None:
    """The guardian makes its process a subreaper for the run only."""
    assert not lifetime.is_subreaper()
    adoption = lifetime.Adoption()
    try:
        assert lifetime.is_subreaper()
    finally:
        adoption.close()
    assert not lifetime.is_subreaper()


def test_ending_spares_what_is_not_the_models(tmp_path: Path) -> None:
    """Children the process had before the model's child was forked are not ended."""
    older = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        adoption = lifetime.Adoption()
        pid = os.fork()
        if pid == 0:
            os._exit(0)
        adoption.forked(pid)
        os.waitpid(pid, 0)
        adoption.close()
        time.sleep(0.1)
        assert older.poll() is None
    finally:
        older.send_signal(signal.SIGKILL)
        older.wait()
