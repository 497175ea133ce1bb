"""A process that ``multiprocessing`` spawns from the ``fmionnx`` console script (a local
study's Dask workers) does not run the script again, so it never imports the command line,
and it ignores Ctrl-C from its first statements (the driver decides)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

#: A console script as pip writes it, that spawns one process running ``{probe}`` (of
#: tests/cli/spawn_probe.py) and prints its answer, then whether its own SIGINT is Python's.
SCRIPT = """\
import signal, sys
from fmionnx.cli import main, _children_skip_the_script
if __name__ == "__main__":
    {skip}
    import multiprocessing
    from tests.cli.spawn_probe import {probe}
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target={probe}, args=(queue,))
    child.start()
    print(queue.get(timeout=60), signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    child.join()
"""


def _spawn_probe(tmp_path: Path, probe: str, *, skip: bool) -> list[str]:
    """What :data:`SCRIPT` prints, run as the console script (only that name is changed)."""
    script = tmp_path / "fmionnx"
    call = "_children_skip_the_script()" if skip else "pass"
    script.write_text(SCRIPT.format(skip=call, probe=probe), encoding="utf-8")
    done = _run_script(script)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


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
    assert _spawn_probe(tmp_path, "report", skip=skip) == [str(imported), "True"]


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


@pytest.mark.parametrize(("skip", "ignored"), [(True, True), (False, False)])
def test_a_spawned_process_ignores_ctrl_c_from_its_start(
    tmp_path: Path, skip: bool, ignored: bool
) -> None:
    """A Ctrl-C while a worker imported Dask printed a traceback; the driver keeps its own."""
    assert _spawn_probe(tmp_path, "sigint_ignored", skip=skip) == [str(ignored), "True"]


def test_importing_the_spawned_main_elsewhere_changes_nothing() -> None:
    done = subprocess.run(
        [sys.executable, "-c", "import signal, fmionnx.spawned\n"
         "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)"],
        cwd=REPO, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.stdout.strip() == "True", done.stderr
