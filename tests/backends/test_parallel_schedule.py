"""The parallel schedule: same values as the sequential one, real overlap, faults as before.

See docs/execution.md, "Parallel schedule". The bit-identity tests compare every recorded
column byte for byte (and the reference scenario's results.csv with its pinned sha256); the
overlap test lets two probed steps meet in the middle, which only concurrent steps can do.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.core.runner import Runner, Wiring, fault
from fmionnx.core.types import Component
from fmionnx.kinds.registry import make_runner
from fmionnx.results.csvfile import write_csv
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.backends.test_sign_follower import REFERENCE_RESULTS_SHA256, SYSTEM
from tests.conftest import REPO, built_model

SEQUENTIAL = RunOptions(schedule="sequential")


def _assert_identical(a: RunResult, b: RunResult) -> None:
    assert (a.status, a.steps_done) == (b.status, b.steps_done)
    assert str(a.error) == str(b.error)
    assert list(a.signals) == list(b.signals)
    for name, values in b.signals.items():
        assert a.signals[name].tobytes() == values.tobytes(), name


def _multi_rate(fixture_fmu, write_system) -> Path:
    """Four rates, a rate transition read later, independent branches and a cut loop."""
    gain, integrator = fixture_fmu("Gain"), fixture_fmu("Integrator")
    return write_system(
        f"""
fmionnx: 1
name: multi_rate_parallel
run: {{stop: 0.6, step: 0.01}}
components:
  src: {{kind: fmu, path: {gain}, parameters: {{k: 1.3, v: [0.1, 0.2, 0.3]}}}}
  slow: {{kind: fmu, path: {integrator}, period: 0.05, parameters: {{x0: 0.25}}}}
  side: {{kind: fmu, path: {gain}, period: 0.02, parameters: {{k: 0.7}}}}
  mid: {{kind: fmu, path: {gain}, period: 0.03, parameters: {{k: 0.9}}}}
  fast: {{kind: fmu, path: {integrator}}}
connections:
  - {{from: src.y, to: slow.u, factor: 0.1, offset: 0.3}}
  - src.w -> side.v
  - {{from: 'src.w[2]', to: side.u, factor: 3.7, offset: -0.11}}
  - slow.x -> mid.u
  - side.y -> mid.v[1]
  - mid.y -> fast.u
  - {{from: fast.x, to: src.u, factor: -0.5, offset: 0.7}}
record: [src.u, src.y, slow.u, slow.x, side.y, side.w, mid.u, mid.v, mid.y, fast.x]
"""
    )


def test_multi_rate_fmu_system_is_bit_identical_in_parallel(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_multi_rate(fixture_fmu, write_system))
    every = frozenset(c.name for c in system.compiled.components)
    sequential = system.run(options=RunOptions(schedule="sequential", isolate=every))
    parallel = system.run(options=RunOptions(isolate=every))
    assert parallel.status is RunStatus.COMPLETED
    assert parallel.details["schedule"] == "parallel"
    assert sequential.details["concurrent_steps"] == 0
    assert int(parallel.details["concurrent_steps"] or 0) > 0  # steps really ran on workers
    _assert_identical(parallel, sequential)
    _assert_identical(system.run(options=SEQUENTIAL), sequential)  # in-process, native kernel


def test_reference_scenario_in_parallel_keeps_the_pinned_results(tmp_path) -> None:
    """Isolated FMUs (the CLI default): odometry's round trip overlaps the camera and detector."""
    built_model("ReadOdometry.fmu")
    options = RunOptions(isolate=frozenset({"odometry", "tracker"}))
    result = fmionnx.load(SYSTEM).run(options=options)
    assert result.status is RunStatus.COMPLETED
    assert result.details["concurrent"] == "odometry"
    assert result.details["concurrent_steps"] == 320  # once per camera frame
    written = write_csv(result, tmp_path / "results.csv")
    assert hashlib.sha256(written.read_bytes()).hexdigest() == REFERENCE_RESULTS_SHA256


# -- a probe around real runners: where and when their steps ran -----------------------------


@dataclass
class Probe:
    """Records each probed step's thread and interval; two probed steps can meet halfway."""

    meet: float = 0.0
    fail_at: dict[str, float] = field(default_factory=dict)
    hang_at: dict[str, float] = field(default_factory=dict)
    delay: float = 0.0
    steps: list[tuple[str, float, int, float, float]] = field(default_factory=list)
    started: dict[tuple[str, float], threading.Event] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def event(self, name: str, t: float) -> threading.Event:
        with self.lock:
            return self.started.setdefault((name, round(t, 9)), threading.Event())

    def factory(self, probed: set[str]) -> Any:
        def make(component: Component, wiring: Wiring) -> Runner:
            runner = make_runner(component, wiring)
            return ProbedRunner(runner, self) if component.name in probed else runner

        return make


class ProbedRunner:
    """A real runner whose step is recorded, may wait for its partner, and may fault."""

    releases_gil = True  # it sleeps and waits: the parallel schedule may hand it to a worker

    def __init__(self, inner: Runner, probe: Probe) -> None:
        self._inner = inner
        self._probe = probe
        self.component = inner.component
        self.lazy_outputs = inner.lazy_outputs

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def step(self, t: float, h: float) -> None:
        probe, name = self._probe, self.component.name
        begin = time.monotonic()
        if probe.meet:
            probe.event(name, t).set()
            partner = "b" if name == "a" else "a"
            probe.event(partner, t).wait(probe.meet)
        if probe.delay:
            time.sleep(probe.delay)
        hang_at = probe.hang_at.get(name)
        if hang_at is not None and t >= hang_at - 1e-12:
            time.sleep(3600)  # never returns within a test: the watchdog must act
        fail_at = probe.fail_at.get(name)
        if fail_at is not None and t >= fail_at - 1e-12:
            raise fault(name, "the probe fails here", time=t)
        self._inner.step(t, h)
        with probe.lock:
            probe.steps.append((name, t, threading.get_ident(), begin, time.monotonic()))


def _two_branches(
    fixture_fmu, write_system, stop: float = 0.05, sinks: float = 0.01, source: str = "Gain"
) -> Path:
    """``a -> sink_a`` and ``b -> sink_b``: no path between a and b; sinks every ``sinks`` s.

    ``source``: the model of a and b (``Gain``: constant outputs, ``Integrator``: ramps).
    """
    gain, model = fixture_fmu("Gain"), fixture_fmu(source)
    out = "y" if source == "Gain" else "x"
    return write_system(
        f"""
fmionnx: 1
name: branches
run: {{stop: {stop}, step: 0.01}}
components:
  a: {{kind: fmu, path: {model}, parameters: {{u: 0.5}}}}
  b: {{kind: fmu, path: {model}, parameters: {{u: 0.25}}}}
  sink_a: {{kind: fmu, path: {gain}, period: {sinks}}}
  sink_b: {{kind: fmu, path: {gain}, period: {sinks}}}
connections:
  - a.{out} -> sink_a.u
  - b.{out} -> sink_b.u
"""
    )


def _run(
    path: Path, probe: Probe, probed: set[str], schedule: str = "parallel", **options: Any
) -> RunResult:
    compiled = fmionnx.load(path).compiled
    chosen = RunOptions(schedule=schedule, **options)  # type: ignore[arg-type]
    return Master(compiled, chosen, probe.factory(probed)).run()


def test_parallel_schedule_really_overlaps_independent_steps(fixture_fmu, write_system) -> None:
    path = _two_branches(fixture_fmu, write_system)
    probe = Probe(meet=10.0)  # each step waits (at most 10 s) for its partner to start
    result = _run(path, probe, {"a", "b"})
    assert result.status is RunStatus.COMPLETED
    main = threading.get_ident()
    steps = {
        (name, round(t, 9)): (thread, begin, end) for name, t, thread, begin, end in probe.steps
    }
    for n in range(5):
        t = round(n * 0.01, 9)
        a_thread, a_begin, a_end = steps[("a", t)]
        b_thread, b_begin, b_end = steps[("b", t)]
        # order a, b, then sink_a and sink_b stepped as one native group: a is followed by b,
        # which does not read it, so a runs on a worker; b is followed by the group, which
        # reads b, so b runs on the loop's thread. Each waited for the other to start.
        assert a_thread != main
        assert b_thread == main
        assert a_begin < b_end
        assert b_begin < a_end
    assert result.details["concurrent"] == "a"


def test_sequential_schedule_runs_every_step_on_the_loops_thread(fixture_fmu, write_system) -> None:
    path = _two_branches(fixture_fmu, write_system, stop=0.02)
    probe = Probe(meet=0.05)  # the partner never comes: each step waits its 50 ms out
    result = _run(path, probe, {"a", "b"}, schedule="sequential")
    assert result.status is RunStatus.COMPLETED
    main = threading.get_ident()
    assert {thread for _, _, thread, _, _ in probe.steps} == {main}
    intervals = sorted((begin, end) for _, _, _, begin, end in probe.steps)
    assert all(e1 <= b2 for (_, e1), (b2, _) in itertools.pairwise(intervals))
    assert result.details["concurrent_steps"] == 0


@pytest.mark.parametrize("at", [0.03, 0.0])
def test_fault_in_a_concurrent_step_is_reported_as_in_the_sequential_run(
    fixture_fmu, write_system, at: float
) -> None:
    path = _two_branches(fixture_fmu, write_system, stop=0.1)
    runs = {}
    for schedule in ("parallel", "sequential"):
        probe = Probe(fail_at={"a": at})
        runs[schedule] = _run(path, probe, {"a", "b"}, schedule=schedule)
    parallel, sequential = runs["parallel"], runs["sequential"]
    assert parallel.status is RunStatus.FAULT
    assert parallel.error is not None
    assert (parallel.error.component, parallel.error.time) == ("a", pytest.approx(at))
    assert parallel.details["concurrent_steps"] == round(at / 0.01) + 1  # the failing one too
    _assert_identical(parallel, sequential)  # every completed step written, nothing after


def _isolated_faulty(fixture_fmu, write_system, mode: int) -> Path:
    """bad (concurrent: other does not read it) and other (a ramp) both feed sink."""
    gain, faulty, integrator = fixture_fmu("Gain"), fixture_fmu("Faulty"), fixture_fmu("Integrator")
    return write_system(
        f"""
fmionnx: 1
name: faulty_parallel
run: {{stop: 1.0, step: 0.01}}
components:
  bad: {{kind: fmu, path: {faulty}, parameters: {{u: 0.5, mode: {mode}, failAt: 0.3}}}}
  other: {{kind: fmu, path: {integrator}, parameters: {{u: 0.25}}}}
  sink: {{kind: fmu, path: {gain}}}
connections:
  - bad.y -> sink.u
  - other.x -> sink.v[1]
"""
    )


@pytest.mark.parametrize(("mode", "status"), [(0, RunStatus.FAULT), (10, RunStatus.COMPLETED)])
def test_isolated_fmu_failing_or_ending_the_run_concurrently(
    fixture_fmu, write_system, mode: int, status: RunStatus
) -> None:
    """A real FMU in its own process: fmi2Error (a fault) or terminateSimulation (an end)."""
    system = fmionnx.load(_isolated_faulty(fixture_fmu, write_system, mode))
    isolate = frozenset({"bad", "other", "sink"})
    parallel = system.run(options=RunOptions(isolate=isolate))
    sequential = system.run(options=RunOptions(isolate=isolate, schedule="sequential"))
    assert parallel.status is status
    assert int(parallel.details["concurrent_steps"] or 0) > 0
    if status is RunStatus.FAULT:
        assert parallel.error is not None
        assert (parallel.error.component, parallel.error.time) == ("bad", pytest.approx(0.3))
    else:
        assert parallel.ended_by is not None
        assert sequential.ended_by is not None
        assert parallel.ended_by.as_dict() == sequential.ended_by.as_dict()
    _assert_identical(parallel, sequential)


HANG_SCRIPT = """
import json, sys
from pathlib import Path
from tests.backends.test_parallel_schedule import Probe, _run

def abandon(result):
    Path(sys.argv[2]).write_text(json.dumps({
        "status": result.status.value, "component": result.error.component,
        "time": result.error.time, "message": str(result.error), "steps": result.steps_done,
        "signals": {k: v.tolist() for k, v in result.signals.items()},
    }))

_run(Path(sys.argv[1]), Probe(hang_at={"a": 0.03}), {"a", "b"}, step_timeout=1.0, abandon=abandon)
"""


def test_hung_concurrent_step_is_abandoned_naming_it_with_every_completed_step(
    fixture_fmu, write_system, tmp_path
) -> None:
    """The watchdog names the concurrent step the loop waits for, at that step's own time."""
    path = _two_branches(fixture_fmu, write_system, stop=0.1)
    written = tmp_path / "abandoned.json"
    process = subprocess.run(
        [sys.executable, "-c", HANG_SCRIPT, str(path), str(written)],
        check=False, capture_output=True, text=True, timeout=120, cwd=REPO,
    )  # fmt: skip
    assert process.returncode == 1, process.stderr
    abandoned = json.loads(written.read_text())
    assert (abandoned["status"], abandoned["component"]) == ("fault", "a")
    assert abandoned["time"] == pytest.approx(0.03)
    assert "did not return within 1 s" in abandoned["message"]
    sequential = _run(path, Probe(fail_at={"a": 0.03}), {"a", "b"}, schedule="sequential")
    assert abandoned["steps"] == sequential.steps_done
    assert abandoned["signals"] == {k: v.tolist() for k, v in sequential.signals.items()}


# -- the command line --------------------------------------------------------------------------


@pytest.mark.parametrize("schedule", ["parallel", "sequential"])
def test_schedule_option_is_recorded_in_run_json_with_identical_results(
    fixture_fmu, write_system, tmp_path, schedule: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    system = _isolated_faulty(fixture_fmu, write_system, mode=0).read_text()
    path = write_system(system.replace("failAt: 0.3", "failAt: 99"))
    out = tmp_path / schedule
    args = ["run", str(path), "--out", str(out), "--isolate", "all", "--schedule", schedule]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    execution = json.loads((out / "run.json").read_text())["execution"]
    assert execution["schedule"] == schedule
    assert (execution["concurrent"], execution["concurrent_steps"] > 0) == (
        ("bad, sink", True) if schedule == "parallel" else (None, False)
    )
    other = tmp_path / ("sequential" if schedule == "parallel" else "parallel")
    flipped = [*args[:-1], other.name]
    flipped[flipped.index("--out") + 1] = str(other)
    assert CliRunner().invoke(app, flipped).exit_code == 0
    assert (out / "results.csv").read_bytes() == (other / "results.csv").read_bytes()


def test_schedule_option_rejects_an_unknown_value(fixture_fmu, write_system) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    path = _isolated_faulty(fixture_fmu, write_system, mode=0)
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "--schedule", "fast"])
    assert result.exit_code == 2
    assert "--schedule must be `parallel` or `sequential`, not `fast`" in result.output


def test_checkpoints_during_a_parallel_run_hold_the_sequential_values(
    fixture_fmu, write_system
) -> None:
    """A checkpoint waits for the pending steps: each one is a prefix of the final results.

    With the sinks at a fifth of the rate, a's and b's steps are still pending when the next
    communication point (and its checkpoint) begins.
    """
    path = _two_branches(fixture_fmu, write_system, stop=0.3, sinks=0.05, source="Integrator")
    partials: list[RunResult] = []
    result = _run(
        path, Probe(delay=0.01), {"a", "b"}, checkpoint=partials.append, checkpoint_every=0.0,
        progress_every=1,
    )  # fmt: skip
    assert result.status is RunStatus.COMPLETED
    assert int(result.details["concurrent_steps"] or 0) > 0
    _assert_identical(result, _run(path, Probe(), {"a", "b"}, schedule="sequential"))
    assert len(partials) >= 2
    for partial in partials:
        assert partial.status is RunStatus.RUNNING
        rows = partial.steps_done + 1
        for name, values in partial.signals.items():
            assert values.tobytes() == result.signals[name][:rows].tobytes(), name
