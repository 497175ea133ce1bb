"""A process that ``multiprocessing`` spawns from the ``fmionnx`` console script (a local
study's Dask workers) does not run the script again, so it never imports the command line."""

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
