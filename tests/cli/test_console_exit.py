"""The console script ends without the interpreter's teardown, and without losing anything.

:func:`fmionnx.cli.console` hands the exit status to the system once the command is done,
after the ``atexit`` hooks and with the standard streams flushed; where another thread still
runs, or a module that must be torn down was loaded, it exits the normal way. Each case runs a
small program in a process of its own, as the console script does.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

#: A program run like the console script; ``{setup}`` runs first.
PROGRAM = """\
import atexit, os, sys, threading, time
from pathlib import Path
marks = Path(sys.argv.pop(1))

class Torn:
    def __init__(self, path):
        # kept here: the module's names and the builtins are cleared before it goes
        self.path, self.flags = str(path), os.O_CREAT | os.O_WRONLY

    def __del__(self, _open=os.open, _close=os.close):
        _close(_open(self.path, self.flags))

torn = Torn(marks / "teardown")  # deleted (its __del__ called) by the interpreter's teardown
atexit.register(lambda: (marks / "atexit").write_text("ran"))
{setup}
from fmionnx.cli import console
sys.argv[0] = "fmionnx"
console()
"""


def _run(tmp_path: Path, args: list[str], setup: str = "") -> tuple[int, str, set[str]]:
    marks = tmp_path / "marks"
    marks.mkdir()
    done = subprocess.run(
        [sys.executable, "-c", PROGRAM.format(setup=setup), str(marks), *args],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    return done.returncode, done.stdout + done.stderr, {p.name for p in marks.iterdir()}


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (["schema"], 0),
        (["validate", "no-such-system.yaml"], 1),
        (["run", "--no-such-option"], 2),
    ],
)
def test_the_status_and_the_output_survive_and_the_teardown_is_skipped(
    tmp_path: Path, args: list[str], code: int
) -> None:
    status, output, marks = _run(tmp_path, args)
    assert status == code, output
    assert "atexit" in marks  # the hooks ran
    assert "teardown" not in marks  # the interpreter's teardown did not
    if args[0] == "schema":
        assert output.rstrip().endswith("}")  # the whole schema, flushed into the pipe


def test_a_thread_still_running_gets_the_normal_exit(tmp_path: Path) -> None:
    setup = (
        "def late():\n"
        "    time.sleep(0.3)\n"
        "    (marks / 'thread').write_text('done')\n"
        "threading.Thread(target=late).start()\n"
    )
    status, output, marks = _run(tmp_path, ["schema"], setup)
    assert status == 0, output
    assert {"thread", "atexit"} <= marks  # the thread was joined (os._exit would have cut it)


def test_a_network_session_module_gets_the_normal_exit(tmp_path: Path) -> None:
    setup = "import types; sys.modules['zenoh'] = types.ModuleType('zenoh')\n"
    status, output, marks = _run(tmp_path, ["validate", "no-such-system.yaml"], setup)
    assert status == 1, output
    assert {"atexit", "teardown"} <= marks


def test_a_message_as_the_exit_code_is_printed_with_status_1(tmp_path: Path) -> None:
    setup = (
        "import fmionnx.cli\n"
        "def stop():\n"
        "    raise SystemExit('stopped: a message')\n"
        "fmionnx.cli.main = stop\n"
    )
    status, output, marks = _run(tmp_path, [], setup)
    assert status == 1
    assert "stopped: a message" in output
    assert "atexit" in marks
    assert "teardown" not in marks
