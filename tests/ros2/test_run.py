"""``fmionnx run --backend ros2``: real node processes on loopback DDS, a random domain.

Lockstep equals in-process bit for bit; a crashed node or Ctrl-C stops the run and leaves no
process behind (checked in /proc by a marker every node's command line carries: the test's
own output folder).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import build_fixture_fmu

pytestmark = pytest.mark.ros2


def fmionnx(*args: str | Path) -> list[str]:
    """The command line of ``fmionnx ARGS`` in this interpreter."""
    return [sys.executable, "-m", "fmionnx", *map(str, args)]


def processes_with(marker: str) -> list[int]:
    """Live (not zombie) processes whose command line mentions ``marker``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if marker in cmdline and state != "Z":
            found.append(int(entry.name))
    return found


def wait_for_nodes(marker: str, count: int, timeout: float = 60.0) -> list[int]:
    """Wait until ``count`` node processes run; their pids."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        nodes = [p for p in processes_with(marker) if _is_node(p)]
        if len(nodes) >= count:
            return nodes
        time.sleep(0.2)
    pytest.fail(f"{count} node processes did not start")


def _is_node(pid: int) -> bool:
    try:
        return b"\0node\0" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


@pytest.fixture
def supervised(loopback_env) -> Iterator[list[subprocess.Popen[str]]]:
    """Supervisor processes that are always reaped."""
    started: list[subprocess.Popen[str]] = []
    yield started
    for process in started:
        if process.poll() is None:
            process.kill()
        process.communicate(timeout=30)


LOOP = """
fmionnx: 1
name: loop
run: {{stop: {stop}, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}, parameters: {{k: -0.8}}}}
  integ: {{kind: fmu, path: {integ}, period: 0.05, parameters: {{x0: 1.0}}}}
  integ2: {{kind: fmu, path: {integ}, period: 0.02}}
connections:
  - integ.x -> gain.u         # a loop, cut at the integrator's state
  - gain.y -> integ.u
  - gain.w[2] -> integ2.u     # an element of an array port
  - integ.x -> gain.v[2]
"""


def loop_system(folder: Path, stop: float) -> Path:
    """Three test FMUs at three rates in a loop (held values, a cut edge, array elements)."""
    path = folder / "loop.yaml"
    path.write_text(
        LOOP.format(
            stop=stop, gain=build_fixture_fmu("Gain"), integ=build_fixture_fmu("Integrator")
        ),
        encoding="utf-8",
    )
    return path


def test_lockstep_run_of_test_fmus_equals_the_inprocess_run_bit_for_bit(
    tmp_path: Path, loopback_env
) -> None:
    system = loop_system(tmp_path, 1.0)
    inprocess, ros2 = tmp_path / "inprocess", tmp_path / "ros2"
    subprocess.run(fmionnx("run", system, "-q", "--out", inprocess), check=True, timeout=60)
    done = subprocess.run(
        fmionnx("run", system, "-q", "--backend", "ros2", "--sync", "lockstep", "--out", ros2),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    expected = (inprocess / "results.csv").read_bytes()
    assert expected.count(b"\n") == 102  # header + 101 rows
    assert (ros2 / "results.csv").read_bytes() == expected
    assert sorted(p.name for p in (ros2 / "logs").iterdir()) == [
        "gain.log", "integ.log", "integ2.log",
    ]  # fmt: skip
    assert '"backend": "ros2"' in (ros2 / "run.json").read_text()
    assert processes_with(str(tmp_path)) == []


def _stepping_loop_run(
    tmp_path: Path, supervised: list[subprocess.Popen[str]], component: str, *args: str
) -> tuple[subprocess.Popen[str], int]:
    """A long lockstep run of the loop system whose ``component`` node is ready; (run, its pid)."""
    out = tmp_path / "out"
    process = subprocess.Popen(
        fmionnx("run", loop_system(tmp_path, 10000.0), "-q", "--backend", "ros2", "--out", out,
                *args),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    supervised.append(process)
    marker = str(tmp_path)
    wait_for_nodes(marker, 3)
    log = out / "logs" / f"{component}.log"
    while not log.exists() or "ready" not in log.read_text():
        time.sleep(0.2)
    node = next(p for p in processes_with(marker) if _is_node(p) and _component(p) == component)
    return process, node


def test_killed_node_stops_the_run_naming_it_and_leaves_no_process(
    tmp_path: Path, supervised
) -> None:
    process, victim = _stepping_loop_run(tmp_path, supervised, "integ")
    os.kill(victim, signal.SIGKILL)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1
    text = " ".join(stderr.split())  # rich wraps long lines
    assert "node /integ (component `integ`) was killed by signal 9 (SIGKILL)" in text
    assert "its last log lines: " in text
    assert "integ INFO node /integ (integ) ready, sync lockstep" in text
    assert processes_with(str(tmp_path)) == []


def test_a_hung_node_ends_a_lockstep_run_after_the_step_timeout_naming_it(
    tmp_path: Path, supervised
) -> None:
    process, victim = _stepping_loop_run(tmp_path, supervised, "integ2", "--step-timeout", "2")
    time.sleep(1.0)  # the run is stepping
    os.kill(victim, signal.SIGSTOP)  # alive, but never answers again
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1, stderr
    text = " ".join(stderr.split())
    assert "did not finish within 2 s: still waiting for /integ2 (component `integ2`)" in text
    assert "--step-timeout" in text
    assert processes_with(str(tmp_path)) == []


def _component(pid: int) -> str:
    args = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    return args[args.index(b"node") + 2].decode()


def test_ctrl_c_stops_the_supervisor_and_every_node(tmp_path: Path, supervised) -> None:
    system = loop_system(tmp_path, 10000.0)
    out = tmp_path / "out"
    # PYTHONFAULTHANDLER: the supervisor ended by SIGSEGV instead of 130 in 2 of 9 full
    # suites once (not reproduced alone); if it happens again, its stack is in the message.
    process = subprocess.Popen(
        fmionnx("run", system, "-q", "--backend", "ros2", "--out", out),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
    )
    supervised.append(process)
    marker = str(tmp_path)
    wait_for_nodes(marker, 3)
    time.sleep(3.0)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, (stdout[-2000:], stderr)
    assert stdout.strip().splitlines()[-1] == f"Results: {out}"
    assert processes_with(marker) == []


def test_fault_inside_a_node_ends_the_run_with_that_fault_and_the_results_so_far(
    tmp_path: Path, loopback_env
) -> None:
    system = tmp_path / "faulty.yaml"
    system.write_text(
        f"""
fmionnx: 1
name: faulty
run: {{stop: 1.0, step: 0.01}}
components:
  bad: {{kind: fmu, path: {build_fixture_fmu("Faulty")}, parameters: {{failAt: 0.3}}}}
  gain: {{kind: fmu, path: {build_fixture_fmu("Gain")}}}
connections:
  - bad.y -> gain.u
""",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    done = subprocess.run(
        fmionnx("run", system, "-q", "--backend", "ros2", "--out", out),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 1
    text = " ".join(done.stderr.split())
    assert "fault: component `bad` at t=0.3 s: fmi2DoStep returned Error" in text
    info = (out / "run.json").read_text()
    assert '"status": "fault"' in info
    inprocess = tmp_path / "inprocess"
    subprocess.run(fmionnx("run", system, "-q", "--out", inprocess), timeout=60, check=False)
    expected = (inprocess / "results.csv").read_bytes()
    assert expected.count(b"\n") == 32  # header + t = 0 .. 0.3, as far as the run got
    assert (out / "results.csv").read_bytes() == expected
    assert processes_with(str(tmp_path)) == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--middleware", "mqtt"], "--middleware must be `dds`, `rclpy` or `zenoh`, not `mqtt`"),
        (["--sync", "loose"], "--sync must be `lockstep` or `free`"),
        (["--ros-distro", "rolling"], "--ros-distro must be one of"),
        (["--step-timeout", "0"], "--step-timeout must be > 0 seconds"),
        (["--rtf", "nan"], "--rtf must be a finite number >= 0"),
    ],
)
def test_ros2_backend_options_are_checked_before_anything_starts(
    tmp_path: Path, args: list[str], message: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    result = CliRunner().invoke(
        app, ["run", str(loop_system(tmp_path, 1.0)), "--backend", "ros2", *args]
    )
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())


def test_ros2_run_writes_no_file_through_a_planted_link(tmp_path: Path, loopback_env) -> None:
    # links planted where the supervisor writes logs, node records and the topic recording:
    # each is replaced by the run's own file, and what they pointed at is left untouched
    system = loop_system(tmp_path, 0.2)
    out = tmp_path / "out"
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n", encoding="utf-8")
    planted = [out / "logs" / "gain.log", out / "nodes" / "integ.json", out / "wire.mcap"]
    for link in planted:
        link.parent.mkdir(parents=True, exist_ok=True)
        link.symlink_to(victim)
    done = subprocess.run(
        fmionnx("run", system, "-q", "--backend", "ros2", "--out", out, "--force",
                "--record", out / "wire.mcap"),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert victim.read_text(encoding="utf-8") == "precious\n"
    for path in planted:
        assert path.is_file(), path
        assert not path.is_symlink(), path
