"""Misbehaving models never take the run down (``--isolate``, ``--step-timeout``, checkpoints).

The Faulty test FMU (compiled from C in the test set-up) crashes, aborts, exits, hangs or
floods its output on purpose in the step starting at ``failAt``. Whatever it does, ``fmionnx
run`` exits 1 with a diagnostic naming the component, the FMI function and the time, and
writes every completed step; no temporary folder is left behind.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.core.runner import Runner, RunnerFactory, Wiring
from fmionnx.core.types import Component
from fmionnx.results.csvfile import read_csv
from fmionnx.runtime.instruments import Instruments
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions, RunStatus
from tests.conftest import finish

SYSTEM = """
fmionnx: 1
name: faulty
run: {{stop: {stop}, step: {step}}}
components:
  bad: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}, failAt: {fail_at}}}}}
  gain: {{kind: fmu, path: {gain}}}
connections:
  - bad.y -> gain.u
"""

SEGFAULT, ABORT, EXIT, HANG, FLOOD = 3, 4, 5, 6, 7
PRINT = 11


def _system(fixture_fmu, write_system, mode: int, *, stop=1.0, step=0.01, fail_at=0.3) -> Path:
    return write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=mode, stop=stop,
            step=step, fail_at=fail_at,
        )
    )  # fmt: skip


def _cli(args: list[str], tmp: Path) -> subprocess.Popen[str]:
    """``fmionnx ARGS`` in a child whose temporary folders go to ``tmp`` (to check clean-up)."""
    code = "import sys; from fmionnx.cli import main; sys.argv[0] = 'fmionnx'; main()"
    tmp.mkdir(exist_ok=True)
    return subprocess.Popen(
        [sys.executable, "-c", code, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, COLUMNS="300", TMPDIR=str(tmp)),
    )


def _finish(process: subprocess.Popen[str], timeout: float = 60) -> tuple[int, str]:
    """Exit status, and stderr then stdout (whose last line names the results folder)."""
    out, err = finish(process, timeout)
    return process.returncode, err + out


def _assert_results_up_to(out: Path, last_time: float) -> dict[str, np.ndarray]:
    table = read_csv(out / "results.csv")
    assert table["time"][-1] == pytest.approx(last_time)
    assert np.isfinite(table["bad.y"]).all()
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "fault"
    assert info["error"]["component"] == "bad"
    return table


@pytest.mark.parametrize(
    ("mode", "how"),
    [
        (SEGFAULT, "crashed with SIGSEGV in fmi2DoStep"),
        (ABORT, "crashed with SIGABRT in fmi2DoStep"),
        (EXIT, "ended its process with exit status 3 in fmi2DoStep"),
        (FLOOD, "fmi2DoStep returned Error"),
    ],
)
def test_isolated_model_that_kills_its_process_is_a_fault_with_results(
    fixture_fmu, write_system, tmp_path: Path, mode: int, how: str
) -> None:
    system = _system(fixture_fmu, write_system, mode)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    code, output = _finish(_cli(["run", str(system), "--out", str(out)], tmp))  # default: fmus
    assert code == 1, output
    assert f"component `bad` at t=0.3 s: the model {how}" in output or (
        mode == FLOOD and f"component `bad` at t=0.3 s: {how}" in output
    ), output
    assert output.rstrip().endswith(f"Results: {out}")
    table = _assert_results_up_to(out, 0.3)  # every completed step: 0 .. 0.3
    assert len(table["time"]) == 31
    assert list(tmp.iterdir()) == []  # extraction folders and the child's folder are gone


def test_flooding_model_log_is_cut_in_the_fault_message(
    fixture_fmu, write_system, tmp_path
) -> None:
    system = _system(fixture_fmu, write_system, FLOOD)
    result = fmionnx.load(system).run(options=RunOptions(isolate=frozenset({"bad"})))
    assert result.status is RunStatus.FAULT
    assert 600 < len(str(result.error)) < 1000  # the model logged 8 MiB


def test_isolated_hang_is_killed_at_the_step_timeout(fixture_fmu, write_system, tmp_path) -> None:
    system = _system(fixture_fmu, write_system, HANG)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    started = time.monotonic()
    args = ["run", str(system), "--out", str(out), "--step-timeout", "1"]
    code, output = _finish(_cli(args, tmp))
    assert code == 1, output
    assert time.monotonic() - started < 30
    assert "component `bad` at t=0.3 s: fmi2DoStep did not return within 1 s" in output
    _assert_results_up_to(out, 0.3)
    assert list(tmp.iterdir()) == []


def test_in_process_hang_abandons_the_run_with_its_results(
    fixture_fmu, write_system, tmp_path
) -> None:
    # gain by model exchange: the Faulty FMU is stepped alone, so the fault can name it
    system = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=f"{fixture_fmu('Gain')}, interface: me", mode=HANG,
            stop=1.0, step=0.01, fail_at=0.3,
        )
    )  # fmt: skip
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--isolate", "none", "--step-timeout", "1"]
    code, output = _finish(_cli(args, tmp))
    assert code == 1, output
    assert "at t=0.3 s: a step did not return within 1 s" in output
    assert "the run was abandoned" in output
    assert output.rstrip().endswith(f"Results: {out}")
    _assert_results_up_to(out, 0.3)


def test_ctrl_c_stops_a_hung_isolated_model(fixture_fmu, write_system, tmp_path) -> None:
    system = _system(fixture_fmu, write_system, HANG)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    process = _cli(["run", str(system), "--out", str(out), "--checkpoint-every", "0"], tmp)
    deadline = time.monotonic() + 60
    while not (out / "results.csv").exists() and time.monotonic() < deadline:
        time.sleep(0.2)  # the first checkpoint: the run is under way
        if process.poll() is not None:
            break
    time.sleep(1.0)
    process.send_signal(signal.SIGINT)
    code, output = _finish(process)
    assert code == 130, output
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted"
    assert list(tmp.iterdir()) == []


def test_checkpoints_keep_the_results_of_a_killed_run(fixture_fmu, write_system, tmp_path) -> None:
    # a long run (the model would hang at t = 60 s): checkpoints, at most every 500 base steps,
    # hold what came before SIGKILL of the whole run
    system = _system(fixture_fmu, write_system, HANG, stop=100.0, step=0.001, fail_at=60.0)
    out, tmp = tmp_path / "out", tmp_path / "tmp"
    args = ["run", str(system), "--out", str(out), "--checkpoint-every", "0"]
    process = _cli(args, tmp)
    deadline = time.monotonic() + 60
    steps = 0
    while time.monotonic() < deadline and process.poll() is None and steps == 0:
        time.sleep(0.1)
        if (out / "run.json").exists():
            steps = json.loads((out / "run.json").read_text())["steps"]
    process.kill()
    process.communicate()
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "running"
    assert info["steps"] > 0
    rows = len(read_csv(out / "results.csv")["time"]) - 1
    # results.csv is replaced before run.json: it may be one checkpoint ahead, never behind
    assert rows >= info["steps"]
    assert rows % 500 == 0


def test_isolated_runs_are_bit_identical_to_in_process_ones(fixture_fmu, write_system) -> None:
    system = fmionnx.load(
        write_system(
            f"""
fmionnx: 1
name: loop
run: {{stop: 2.0, step: 0.001}}
components:
  a: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 0.5}}}}
  b: {{kind: fmu, path: {fixture_fmu("Integrator")}, interface: me}}
connections:
  - a.y -> b.u
  - b.x -> a.u
"""
        )
    )
    plain = system.run(isolate="none")
    for isolate in ({"a"}, {"a", "b"}):
        isolated = system.run(options=RunOptions(isolate=frozenset(isolate)))
        assert isolated.status is RunStatus.COMPLETED
        assert list(isolated.signals) == list(plain.signals)
        for name, values in plain.signals.items():
            assert np.array_equal(values, isolated.signals[name]), name


def test_isolate_names_must_exist(fixture_fmu, write_system, tmp_path) -> None:
    system = _system(fixture_fmu, write_system, 0)
    code, output = _finish(
        _cli(["run", str(system), "--no-out", "--isolate", "bad,nope"], tmp_path / "t")
    )
    assert code == 2
    assert "--isolate: no component named `nope`" in output


WRITE_PROBE, CONNECT_PROBE = 8, 9


def _probe_run(
    fixture_fmu, write_system, tmp_path, mode: int, env: dict[str, str], *extra: str,
    cwd: Path | None = None,
):  # fmt: skip
    system = write_system(
        SYSTEM.format(
            faulty=fixture_fmu("Faulty"), gain=fixture_fmu("Gain"), mode=mode, stop=0.05,
            step=0.01, fail_at=0.02,
        )
    )  # fmt: skip
    code = "import sys; from fmionnx.cli import main; sys.argv[0] = 'fmionnx'; main()"
    return subprocess.run(
        [sys.executable, "-c", code, "run", str(system), "-q", "--no-out", *extra],
        capture_output=True,
        text=True,
        env=dict(os.environ, COLUMNS="300", **env),
        timeout=60,
        check=False,
        cwd=cwd,
    )


def test_sandbox_keeps_a_model_from_writing_outside_its_folder(
    fixture_fmu, write_system, tmp_path
) -> None:
    probe = tmp_path / "written-by-the-model.txt"
    env = {"FMIONNX_PROBE_FILE": str(probe)}
    free = _probe_run(fixture_fmu, write_system, tmp_path, WRITE_PROBE, env)
    assert free.returncode == 0, free.stderr
    assert probe.exists()  # the probe works: unconfined, the model writes where it likes
    probe.unlink()
    confined = _probe_run(fixture_fmu, write_system, tmp_path, WRITE_PROBE, env, "--sandbox")
    assert confined.returncode == 1
    assert "component `bad` at t=0.02 s: fmi2DoStep returned Error" in confined.stderr
    assert "cannot write the probe file: Permission denied" in confined.stderr
    assert not probe.exists()


def test_sandbox_keeps_a_model_off_the_network(fixture_fmu, write_system, tmp_path) -> None:
    import socket

    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        env = {"FMIONNX_PROBE_PORT": str(server.getsockname()[1])}
        free = _probe_run(fixture_fmu, write_system, tmp_path, CONNECT_PROBE, env)
        assert free.returncode == 0, free.stderr  # unconfined, the model connects
        confined = _probe_run(fixture_fmu, write_system, tmp_path, CONNECT_PROBE, env, "--sandbox")
    assert confined.returncode == 1
    # a network namespace refuses the connection; without user namespaces the sandbox's
    # system-call filter refuses the socket itself
    assert "Faulty: cannot connect" in confined.stderr or "Faulty: cannot open a socket" in (
        confined.stderr
    )


def test_a_sandboxed_model_loads_whatever_the_working_folder(
    fixture_fmu, write_system, tmp_path
) -> None:
    """The confined child may read fmionnx's own files wherever they are installed: from a
    source checkout (an editable install), they were readable only when the run started in
    that checkout, the one folder of ``sys.path`` that held them."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    done = _probe_run(fixture_fmu, write_system, tmp_path, PRINT, {}, "--sandbox", cwd=elsewhere)
    assert done.returncode == 0, done.stderr


def test_sandboxed_models_give_the_same_results(fixture_fmu, write_system, tmp_path) -> None:
    system = _system(fixture_fmu, write_system, 0, fail_at=5.0)  # never fails
    runs = {}
    for name, extra in {"plain": ["--isolate", "none"], "sandboxed": ["--sandbox"]}.items():
        out = tmp_path / name
        code, output = _finish(
            _cli(["run", str(system), "--out", str(out), *extra], tmp_path / "t")
        )
        assert code == 0, output
        runs[name] = (out / "results.csv").read_bytes()
    assert runs["plain"] == runs["sandboxed"]


def test_isolated_models_are_made_after_the_in_process_ones(fixture_fmu, write_system) -> None:
    """Their children wait for the zygote's imports, which go on while the in-process models
    load (``Master._making_order``); the runners stay in the system's order, and so do the
    results, column for column and byte for byte."""
    from tests.backends.isolated_runner import assert_completed_alike, isolated_chain

    system, _ = isolated_chain(fixture_fmu, write_system)  # a, b, c, in that order
    made: list[str] = []

    def noting(factory: RunnerFactory) -> RunnerFactory:
        def make(component: Component, wiring: Wiring) -> Runner:
            made.append(component.name)
            return factory(component, wiring)

        return make

    isolate = frozenset({"a", "c"})
    options = RunOptions(isolate=isolate, profile=True, instruments=Instruments(runners=noting))
    result = system.run(options=options)
    assert made == ["b", "a", "c"]
    assert_completed_alike(system.run(options=RunOptions()), result)

    # and the profile, which a paced run's live view lists in its order
    master = Master(system.compiled, RunOptions(isolate=isolate, profile=True))
    try:
        master.prepare()
        assert list(master.runners) == ["a", "b", "c"]
        assert master.profile is not None
        assert list(master.profile.entries) == ["a", "b", "c"]
    finally:
        master._terminate()
