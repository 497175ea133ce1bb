"""``make test``'s two pytest-xdist workers keep the groups of ``tests/conftest.py``: every DDS
test on one worker, every Zenoh test on one, a file's tests together.

The groups were once given as ``xdist_group`` markers, which pytest 9.2 made xdist ignore
without a word; so this runs a real two-worker session (every test skipped by a probe that
notes its worker) and looks where the tests went.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

from tests.conftest import REPO, worker_group

PROBE = """
import os
import pytest

@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    with open(os.environ["GROUP_PROBE_OUT"], "a", encoding="utf-8") as out:
        out.write(os.environ.get("PYTEST_XDIST_WORKER", "-") + " " + item.nodeid + "\\n")
    pytest.skip("probe")
"""

FILES = [
    "tests/ros2/test_env.py",
    "tests/ros2/test_children.py",
    "tests/ros2/zenoh/test_keys.py",
    "tests/ros2/zenoh/test_zenoh_router.py",
    "tests/compile/test_check_parse.py",
    "tests/compile/test_algebraic_loops.py",
]


def test_the_groups_are_named_after_the_middleware_or_the_file() -> None:
    assert worker_group("tests/ros2/test_run.py::test_x[a]") == "dds"
    assert worker_group("tests/ros2/zenoh/test_zenoh_run.py::test_y") == "zenoh"
    assert worker_group("tests/benchmarks/test_ros2_benchmarks.py::test_z") == "dds"
    assert worker_group("tests/cli/test_outputs.py::test_w[ros2]") == "tests/cli/test_outputs.py"


def test_a_two_worker_session_runs_each_group_on_one_worker(tmp_path: Path) -> None:
    files = [f for f in FILES if (REPO / f).is_file()]
    assert files == FILES, "a file this test picked is gone: pick another"
    (tmp_path / "group_probe.py").write_text(PROBE, encoding="utf-8")
    out = tmp_path / "ran.txt"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]),
        "GROUP_PROBE_OUT": str(out),
    }
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "group_probe",
         "-n", "2", "--dist", "loadscope", *files],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    workers: dict[str, set[str]] = defaultdict(set)
    for line in out.read_text(encoding="utf-8").splitlines():
        worker, nodeid = line.split(" ", 1)
        workers[worker_group(nodeid)].add(worker)
    assert {"dds", "zenoh"} <= workers.keys()
    assert {group: len(ran_on) for group, ran_on in workers.items()} == dict.fromkeys(workers, 1)
