"""A process that ``multiprocessing`` spawns from the ``fmionnx`` console script (a local
study's Dask workers) does not run the script again, so it never imports the command line,
and it ignores Ctrl-C from its first statements (the driver decides)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

#: A console script as pip writes it, that spawns one process and prints what it imported.
SCRIPT = """\
import sys
from fmionnx.cli import main, _children_skip_the_script
if __name__ == "__main__":
    {skip}
    import multiprocessing
    from tests.cli.spawn_probe import report
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=report, args=(queue,))
    child.start()
    print("child imported the command line:", queue.get(timeout=60))
    child.join()
"""


def _run_script(script: Path) -> subprocess.CompletedProcess[str]:
    """``python SCRIPT`` from the repository, with this checkout importable."""
    return subprocess.run(
        [sys.executable, str(script)], cwd=REPO, capture_output=True, text=True, timeout=120,
        env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}, check=False,
    )  # fmt: skip


@pytest.mark.parametrize(("skip", "imported"), [(True, False), (False, True)])
def test_a_spawned_process_leaves_the_console_script_alone(
    tmp_path: Path, skip: bool, imported: bool
) -> None:
    script = tmp_path / "fmionnx"  # the console script's name: only that one is changed
    call = "_children_skip_the_script()" if skip else "pass"
    script.write_text(SCRIPT.format(skip=call), encoding="utf-8")
    done = _run_script(script)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"child imported the command line: {imported}"


def test_a_main_module_of_another_name_keeps_its_spec(tmp_path: Path) -> None:
    script = tmp_path / "my_tool.py"
    script.write_text(
        "import sys\nfrom fmionnx.cli import _children_skip_the_script\n"
        "_children_skip_the_script()\nprint(sys.modules['__main__'].__spec__)\n",
        encoding="utf-8",
    )
    done = _run_script(script)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "None"


PROBE_SIGINT = """\
import signal
from fmionnx.cli import _children_skip_the_script
if __name__ == "__main__":
    {skip}
    import multiprocessing
    from tests.cli.spawn_probe import sigint_ignored
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=sigint_ignored, args=(queue,))
    child.start()
    print(queue.get(timeout=60), signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    child.join()
"""


@pytest.mark.parametrize(("skip", "ignored"), [(True, True), (False, False)])
def test_a_spawned_process_ignores_ctrl_c_from_its_start(
    tmp_path: Path, skip: bool, ignored: bool
) -> None:
    """A Ctrl-C while a worker imported Dask printed a traceback; the driver keeps its own."""
    script = tmp_path / "fmionnx"
    call = "_children_skip_the_script()" if skip else "pass"
    script.write_text(PROBE_SIGINT.format(skip=call), encoding="utf-8")
    done = _run_script(script)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(ignored), "True"]


def test_importing_the_spawned_main_elsewhere_changes_nothing() -> None:
    done = subprocess.run(
        [sys.executable, "-c", "import signal, fmionnx.spawned\n"
         "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)"],
        cwd=REPO, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.stdout.strip() == "True", done.stderr
