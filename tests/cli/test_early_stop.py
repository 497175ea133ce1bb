"""A Ctrl-C while the command line loads, before any command can catch it, ends in one line.

Found by a bug hunt: SIGINT in the first tenth of a second printed Python's
``KeyboardInterrupt`` traceback (in typer's import), and one during a study's first half
second printed the workers' fork server's. Each case sends a real SIGINT at a chosen moment:
an audit hook sends it when the named module starts to be imported.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

#: The console script, with SIGINT sent to itself as ``{module}`` is imported.
PROGRAM = """\
import os, signal, sys
sent = []
def hook(event, args):
    if event == "import" and args[0] == {module!r} and not sent:
        sent.append(True)
        os.kill(os.getpid(), signal.SIGINT)
sys.addaudithook(hook)
from fmionnx.entry import console
sys.argv[0] = "fmionnx"
console()
"""


@pytest.mark.parametrize(
    "module",
    [
        "typer",  # before the command line can catch anything
        "fmionnx.cli.run_cmd",
        "fmionnx.cli.validate_cmd",
        "fmionnx.compile.compiler",  # inside the command, where typer turned it into exit 130
    ],
)
def test_a_ctrl_c_while_the_command_line_loads_is_one_line(module: str) -> None:
    done = subprocess.run(
        [sys.executable, "-c", PROGRAM.format(module=module), "validate", "missing.yaml"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 128 + signal.SIGINT
    assert done.stdout == ""
    assert done.stderr == "error: interrupted by SIGINT\n"


def test_the_fork_server_ignores_ctrl_c_from_its_start(tmp_path: Path) -> None:
    """The server is started with SIGINT ignored, so it is ignored before its preload's first
    line runs (which ignores it too, half a second later on a busy machine)."""
    program = (
        "from multiprocessing import forkserver\n"
        "from fmionnx.backends.sweep import workerfork\n"
        "assert workerfork.start()\n"
        "pid = forkserver._forkserver._forkserver_pid\n"
        "print(pid, open(f'/proc/{pid}/status').read(), sep='\\n', flush=True)\n"
        "import signal\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler, flush=True)\n"
    )
    env = dict(os.environ, TMPDIR=str(tmp_path))
    done = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, timeout=120,
        check=False, env=env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    ignored = next(int(line.split()[1], 16) for line in lines if line.startswith("SigIgn:"))
    assert ignored & (1 << (signal.SIGINT - 1)), "the server took SIGINT in its first moment"
    assert lines[-1] == "True"  # the command's own Ctrl-C is back as it was
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and Path(f"/proc/{lines[0]}").exists():
        time.sleep(0.05)  # the server ends with the command that started it


def test_a_stop_the_command_line_reported_is_not_said_twice(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A Ctrl-C that broke a C extension's import ends as that import's error, which the
    command line reports as the stop; the exit's chain then ends, and the last word is not
    repeated."""
    from fmionnx.cli import _exit_if_stopped, _say_if_stopped

    broken = ImportError("initialization failed")
    broken.__cause__ = KeyboardInterrupt()  # what the extension's import raised it from
    ended = None
    try:
        raise broken  # handled below as main() handles it
    except ImportError as failed:
        try:
            _exit_if_stopped(failed)
        except SystemExit as exc:
            ended = exc
    assert ended is not None
    assert ended.code == 128 + signal.SIGINT
    _say_if_stopped(ended)
    assert capsys.readouterr().err == (
        "error: interrupted by SIGINT (ImportError: initialization failed)\n"
    )
