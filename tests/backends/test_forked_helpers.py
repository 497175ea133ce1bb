"""A run's helpers forked from the command's process instead of started as new interpreters
(``fmionnx/core/forking.py``): the isolated models' zygote and the plot worker.

``fmionnx run``'s process loads numpy with one BLAS thread and forks both, in a terminal too
(where rich's live display starts a thread: the helpers are forked before it); a program
calling ``fmionnx.run`` starts them as new interpreters, as before. The results and figures
are the same, byte for byte. The copies keep none of the command's descriptors, read no
input, and a stop signal to the command's whole process group ends the run cleanly. Every
case runs in processes of its own, the commands in a terminal (a pseudo-terminal).
"""

from __future__ import annotations

import fcntl
import json
import os
import pty
import select
import shutil
import signal
import struct
import subprocess
import sys
import termios
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from fmionnx.core.forking import BLAS_THREADS
from fmionnx.results.plotworker import wanted as plot_worker_wanted
from tests.conftest import REPO, build_fixture_fmu, finish
from tests.processes import child_pids, command_line, group_members
from tests.results.test_plot_worker import SYSTEM  # a signal, an FMU and two plots


class Terminal:
    """A command whose standard streams are a terminal of its own, in a session of its own
    (its process group is its pid), 200 columns wide; what it writes is read as it comes."""

    def __init__(self, command: list[str], cwd: Path, env: dict[str, str]) -> None:
        ours, theirs = pty.openpty()
        fcntl.ioctl(theirs, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 200, 0, 0))
        self.process = subprocess.Popen(
            command, cwd=cwd, env={**env, "NO_COLOR": "1"}, stdin=theirs, stdout=theirs,
            stderr=theirs, start_new_session=True,
        )  # fmt: skip
        os.close(theirs)
        self._ours = ours
        self.output = ""

    def _read(self, timeout: float) -> bool:
        """Read what came within ``timeout`` seconds; False once the terminal is closed."""
        if not select.select([self._ours], [], [], timeout)[0]:
            return True
        try:
            data = os.read(self._ours, 65536)
        except OSError:  # EIO: every process holding the terminal has closed it
            return False
        self.output += data.decode(errors="replace")
        return bool(data)

    def wait_for(self, text: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.output and time.monotonic() < deadline:
            if not self._read(0.1):
                break
        assert text in self.output, self.output

    def finish(self, timeout: float) -> str:
        """Everything written until the command ended (killed after ``timeout`` seconds)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and self._read(0.1):
            if self.process.poll() is not None and not select.select([self._ours], [], [], 0)[0]:
                break
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        os.close(self._ours)
        return " ".join(self.output.split())  # lines as rich wrapped them, joined


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    return tmp_path


def _environment(**more: str) -> dict[str, str]:
    """This environment without a BLAS thread count (the command's own choice is tested)."""
    inherited = {k: v for k, v in os.environ.items() if k != BLAS_THREADS}
    return {**inherited, "PYTHONPATH": str(REPO), **more}


#: Every Python process started with this on its path writes how it was started (a forked
#: copy starts no interpreter, so it writes nothing).
STARTS = """
import json, os, sys
with open(os.environ["STARTS_LOG"], "a", encoding="utf-8") as log:
    log.write(json.dumps(sys.orig_argv) + "\\n")
"""

#: Runs the system through the Python API with nothing but its main thread (and numpy with
#: one BLAS thread), and prints how each helper was started and how the run ended.
API_RUN = """
import json, os, sys
os.sched_getaffinity = lambda _: {0, 1}  # a plot worker even on a machine of one core
import fmionnx
from fmionnx.results import plotworker
from fmionnx.runtime.isolated import launcher
seen = {}
made = plotworker.PlotWorker.__init__
def recording(self, **how):
    made(self, **how)
    seen["plot worker"] = type(self._process).__name__
plotworker.PlotWorker.__init__ = recording
outcome = fmionnx.run("system.yaml", out="api")
seen["zygote"] = type(launcher._zygote.get()._process).__name__
seen["status"] = outcome.status.value
print(json.dumps(seen))
"""


def _started(folder: Path, *options: str) -> list[list[str]]:
    """The Python interpreters that ``fmionnx run system.yaml OPTIONS`` in a terminal started,
    itself first, each as ``["-m", MODULE]``."""
    site = folder / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(STARTS, encoding="utf-8")
    log = folder / "starts.log"
    log.unlink(missing_ok=True)
    environment = _environment(
        PYTHONPATH=os.pathsep.join([str(site), str(REPO)]), STARTS_LOG=str(log)
    )
    command = [sys.executable, "-m", "fmionnx", "run", "system.yaml", *options]
    terminal = Terminal(command, folder, environment)
    output = terminal.finish(180)
    assert terminal.process.returncode == 0, output
    assert "Traceback" not in output, output
    starts = [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines()]
    return [argv[1:3] for argv in starts]


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".csv", ".png")}


def test_the_command_forks_its_helpers_a_program_starts_them_and_the_results_are_the_same(
    folder: Path,
) -> None:
    assert _started(folder, "--out", "cli") == [["-m", "fmionnx"]]
    # Sandboxed models come from a zygote that holds nothing of the command's.
    assert _started(folder, "--out", "sandboxed", "--sandbox") == [
        ["-m", "fmionnx"],
        ["-m", "fmionnx.runtime.isolated.zygote"],
    ]

    process = subprocess.Popen(
        [sys.executable, "-c", API_RUN], cwd=folder, env=_environment(OPENBLAS_NUM_THREADS="1"),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    out, err = finish(process, 180)
    assert process.returncode == 0, err
    assert "Traceback" not in err, err
    seen = json.loads(out.strip().splitlines()[-1])
    assert seen == {"plot worker": "Popen", "zygote": "Popen", "status": "completed"}

    files = _files(folder / "cli")
    assert set(files) == {"results.csv", "over-time.png", "one-against-the-other.png"}
    assert files == _files(folder / "api")


LONG = """\
fmionnx: 1
name: long
run: {stop: 5000, step: 0.001}
components:
  integ: {kind: fmu, path: Integrator.fmu, parameters: {x0: 1.0, u: 0.5}}
  gain: {kind: fmu, path: Gain.fmu}
connections:
  - integ.x -> gain.u
plots:
  - {y: [integ.x, gain.y]}
"""

#: What a forked helper may hold: the terminal (its standard streams), /dev/null, and the
#: pipes, sockets, shared memory and pidfds of its own work; never a file or folder.
HELPER_DESCRIPTORS = ("/dev/pts/", "/dev/null", "pipe:", "socket:", "anon_inode:", "/memfd:")


def _command_line(pid: int) -> str:
    try:
        return command_line(pid)
    except OSError:  # ended meanwhile
        return ""


def _descriptors(pid: int) -> dict[int, str]:
    folder = Path(f"/proc/{pid}/fd")
    return {int(fd.name): str(fd.readlink()) for fd in folder.iterdir()}


@pytest.fixture
def long_run(folder: Path) -> Iterator[Terminal]:
    """``fmionnx run`` of a long system with two isolated FMUs and a plot, in its loop."""
    shutil.copy(build_fixture_fmu("Integrator"), folder / "Integrator.fmu")
    (folder / "long.yaml").write_text(LONG, encoding="utf-8")
    command = [sys.executable, "-m", "fmionnx", "run", "long.yaml", "--out", "out"]
    # The plot worker follows the rows (shared memory) on 2 cores too.
    terminal = Terminal(command, folder, _environment(FMIONNX_CSV_AHEAD="1"))
    try:
        terminal.wait_for("running long", 120)
        terminal.wait_for("RTF", 60)  # the live display runs: its thread came after the forks
        time.sleep(1.0)  # well into the loop
        yield terminal
    finally:
        if terminal.process.poll() is None:
            os.killpg(terminal.process.pid, signal.SIGKILL)
            terminal.finish(10)


def test_the_forked_helpers_keep_none_of_the_command_s_descriptors(long_run: Terminal) -> None:
    command = command_line(long_run.process.pid)
    helpers = [pid for pid in child_pids(long_run.process.pid) if _command_line(pid) == command]
    held = {pid: _descriptors(pid) for pid in helpers}
    assert len(held) == (2 if plot_worker_wanted() else 1), held  # the zygote, the plot worker
    for descriptors in held.values():
        assert all(t.startswith(HELPER_DESCRIPTORS) for t in descriptors.values()), held
    zygote = [pid for pid in helpers if child_pids(pid)]  # the isolated FMUs' parent
    assert len(zygote) == 1, held
    assert held[zygote[0]][0] == "/dev/null"  # no model reads the command's input
    # Forked before the plot worker's shared rows were mapped: no model can write to them.
    (worker,) = set(helpers) - set(zygote)
    assert "memfd:" in Path(f"/proc/{worker}/maps").read_text()  # the rows are shared
    assert "memfd:" not in Path(f"/proc/{zygote[0]}/maps").read_text()


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_stop_signal_to_the_command_s_group_stops_it_cleanly(
    long_run: Terminal, folder: Path, signum: signal.Signals, code: int
) -> None:
    """A terminal's Ctrl-C (or a service manager's SIGTERM) reaches the whole group, the
    forked zygote and its children too: the run ends as stopped, with its results and no
    traceback, and nothing of the group is left."""
    process = long_run.process
    os.killpg(process.pid, signum)
    output = long_run.finish(120)
    assert process.returncode == code, output
    assert f"interrupted by {signum.name}" in output, output
    assert "Traceback" not in output, output
    assert (folder / "out" / "results.csv").exists()
    deadline = time.monotonic() + 10
    while group_members(process.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert group_members(process.pid) == []


def test_a_command_loads_numpy_with_one_blas_thread_unless_told() -> None:
    """The variable is set only while numpy loads, and never over the environment's."""
    script = (
        "import os, sys; from fmionnx.core.forking import load_numpy_with_one_blas_thread as l;"
        " l(); print(len(os.listdir('/proc/self/task')), os.environ.get('OPENBLAS_NUM_THREADS'))"
    )
    ours = subprocess.run(
        [sys.executable, "-c", script], env=_environment(), capture_output=True, text=True,
        check=True,
    )  # fmt: skip
    assert ours.stdout.split() == ["1", "None"]
    told = subprocess.run(
        [sys.executable, "-c", script], env=_environment(OPENBLAS_NUM_THREADS="3"),
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert told.stdout.split()[1] == "3"


#: Forks a helper that reports its signal handling and waits, then sends the parent a
#: SIGINT its block holds: leaving the block must stop the parent and end the copy first.
HELD_STOP = """
import os, signal, sys, time
from fmionnx.core.forking import forked_helper
signal.signal(signal.SIGTERM, lambda *_: None)  # a Python handler the copy must not keep
read, write = os.pipe()
copies = []
try:
    with forked_helper() as pid:
        if pid == 0:
            report = [signal.getsignal(signal.SIGINT) is signal.SIG_IGN,
                      signal.getsignal(signal.SIGTERM) is signal.SIG_DFL,
                      signal.pthread_sigmask(signal.SIG_BLOCK, ()) == set()]
            os.write(write, repr(report).encode())
            time.sleep(20)  # killed long before, unless that broke
            os._exit(0)
        copies.append(pid)
        print("copy", os.read(read, 100).decode(), flush=True)
        os.kill(os.getpid(), signal.SIGINT)  # held until the block ends
        print("held", flush=True)
except KeyboardInterrupt:
    print("stopped", flush=True)
try:
    os.waitpid(copies[0], os.WNOHANG)
    print("left running")
except ChildProcessError:
    print("reaped")
print("mask", signal.pthread_sigmask(signal.SIG_BLOCK, ()) == set())
"""


def test_a_stop_held_across_the_fork_ends_the_copy_which_handles_signals_as_a_helper() -> None:
    done = subprocess.run(
        [sys.executable, "-c", HELD_STOP], env=_environment(), capture_output=True, text=True,
        check=False,
        timeout=60,
    )  # fmt: skip
    assert done.stdout.splitlines() == [
        "copy [True, True, True]",
        "held",
        "stopped",
        "reaped",
        "mask True",
    ], done.stderr
