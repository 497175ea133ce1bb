"""The workers of the command's local cluster are forked from a server that imported what they
need (fmionnx.backends.sweep.workerfork): children of that server, with Dask's thread budget
and SIGINT ignored from their start, replaced by another fork when one dies, giving the
results spawned workers give; the server is started by the ``fmionnx`` command only, and its
preload does nothing imported anywhere else."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.backends.sweep.workerboot import pre_spawn_environment
from tests.conftest import REPO, finish
from tests.processes import child_pids, command_line
from tests.sweep.conftest import WriteStudy

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

GRID = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [0.5, 2, 3]
  integ.x0: [0, 1]
metrics:
  y_end: final(gain.y)
  y_mean: mean(gain.y)
"""


def _worker_facts() -> dict[str, Any]:
    """On a worker: its parent, what it does with SIGINT, the environment it started with."""
    return {
        "pid": os.getpid(),
        "parent": os.getppid(),
        "sigint_ignored": signal.getsignal(signal.SIGINT) is signal.SIG_IGN,
        "environ": dict(os.environ),
    }


def test_forked_workers_are_the_servers_children_with_dasks_budget_and_ctrl_c_ignored(
    forked: None,
) -> None:
    import cloudpickle

    from fmionnx.backends.sweep.engine import open_client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import us
    budget = pre_spawn_environment()
    assert budget["OMP_NUM_THREADS"] == os.environ.get("OMP_NUM_THREADS", "1")
    with open_client(workers=2) as client:
        client.wait_for_workers(2)
        facts = client.run(_worker_facts)
        servers = {f["parent"] for f in facts.values()}
        assert len(servers) == 1
        assert os.getpid() not in servers
        (server,) = servers
        assert "multiprocessing.forkserver" in command_line(server)
        for fact in facts.values():
            assert fact["sigint_ignored"]
            assert {k: fact["environ"].get(k) for k in budget} == budget
            assert "MALLOC_TRIM_THRESHOLD_" not in fact["environ"]  # fmionnx's setting kept

        # A worker that dies (a crashing model) is replaced by another fork of the server.
        gone = next(iter(facts))
        os.kill(facts[gone]["pid"], signal.SIGKILL)
        deadline = time.monotonic() + 60
        while True:
            now = client.scheduler_info()["workers"]
            if len(now) == 2 and gone not in now:
                break
            assert time.monotonic() < deadline, now
            time.sleep(0.1)
        again = client.run(_worker_facts)
        assert {f["parent"] for f in again.values()} == {server}


def test_a_study_on_forked_workers_gives_what_spawned_workers_give(
    write_study: WriteStudy, tmp_path: Path, request: pytest.FixtureRequest
) -> None:
    study = write_study(GRID)
    spawned = fmionnx.sweep(study, out=tmp_path / "spawned", workers=2)
    request.getfixturevalue("forked")
    forked = fmionnx.sweep(study, out=tmp_path / "forked", workers=2)
    columns = ["case", "gain.k", "integ.x0", "y_end", "y_mean", "status"]
    assert forked[columns].equals(spawned[columns])
    assert (forked["status"] == "ok").all()
    assert forked["worker"].nunique() == 2


def test_the_preload_does_nothing_when_imported_elsewhere() -> None:
    probe = (
        "import os, signal, sys\n"
        "import fmionnx.backends.sweep.workerboot\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler,"
        " 'distributed' in sys.modules, 'OMP_NUM_THREADS' in os.environ)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    done = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["True", "False", "False"]


def test_the_budget_is_dasks_with_the_users_configuration_and_variables(tmp_path: Path) -> None:
    probe = (
        "from fmionnx.backends.sweep.workerboot import pre_spawn_environment\n"
        "print(sorted(pre_spawn_environment().items()))\n"
    )
    env = {
        **{k: v for k, v in os.environ.items() if not k.startswith(("OMP_", "MKL_", "DASK_"))},
        "DASK_CONFIG": str(tmp_path),  # the user's Dask configuration
        "OPENBLAS_NUM_THREADS": "2",  # set in the environment: kept, as the nanny keeps it
    }
    (tmp_path / "dask.yaml").write_text(
        "distributed:\n  nanny:\n    pre-spawn-environ:\n      MKL_NUM_THREADS: 3\n", "utf-8"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True
    )
    expected = [("MKL_NUM_THREADS", "3"), ("OMP_NUM_THREADS", "1"), ("OPENBLAS_NUM_THREADS", "2")]
    assert done.stdout.strip() == str(expected)


def test_the_command_forks_its_workers_and_leaves_nothing_in_the_temporary_folder(
    write_study: WriteStudy, tmp_path: Path
) -> None:
    """``fmionnx sweep`` (the whole process) starts the server: its workers are its children,
    not the command's; its socket's folder is a scratch folder, gone with the command. (The
    temporary folder is a short path: a socket's is limited to 107 bytes, and under a longer
    one the workers are spawned.)"""
    study = write_study(GRID.replace("gain.k: [0.5, 2, 3]", "gain.k: [0.5, 2, 3, 4, 5, 6, 7]"))
    with tempfile.TemporaryDirectory(prefix="fmionnx-test-") as temporary:
        env = {**os.environ, "TMPDIR": temporary}
        command = [
            sys.executable,
            "-m",
            "fmionnx",
            "sweep",
            str(study),
            "--out",
            str(tmp_path / "o"),
        ]
        process = subprocess.Popen(
            [*command, "--workers", "2", "--force", "-q"], cwd=REPO, env=env, text=True,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )  # fmt: skip
        workers: list[int] = []
        while process.poll() is None and not workers:
            servers = [pid for pid in child_pids(process.pid) if _is_fork_server(pid)]
            workers = [pid for server in servers for pid in child_pids(server)]
            time.sleep(0.02)
        _, err = finish(process, 120)
        assert process.returncode == 0, err
        assert workers, "no worker forked by a fork server of the command's"
        assert list(Path(temporary).iterdir()) == []


def test_the_server_ends_without_tearing_down_its_interpreter() -> None:
    """Torn down, the server held the command's standard output for 0.1-0.15 s after the
    command ended (a caller reading it waited): it leaves from its first exit hook."""
    probe = (
        "import atexit, os, signal\n"
        "atexit.register(print, 'torn down')\n"  # runs after boot's hook, if ever
        "from fmionnx.backends.sweep.workerboot import boot\n"
        "boot()\n"
        "print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN, os.environ['OMP_NUM_THREADS'])\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    done = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "1"]


def _is_fork_server(pid: int) -> bool:
    try:
        return "multiprocessing.forkserver" in command_line(pid)
    except OSError:  # ended meanwhile
        return False
