"""The workers of the command's local cluster are forked from a server that imported what they
need (fmionnx.backends.sweep.workerfork): children of that server, started with Dask's thread
budget and hash seed in its environment, its preload run (SIGINT ignored), replaced by another
fork when one dies, giving the results spawned workers give; the server is started by the
``fmionnx`` command only, and its preload does nothing imported anywhere else.

A worker's environment as the nanny leaves it says nothing here (the nanny sets the same
variables in every worker once it runs): what counts is the environment the server *started*
with, before numpy loaded (``/proc/<pid>/environ``), and how the worker hashes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.backends.sweep.workerfork import DASK_HASH_SEED, pre_spawn_environment
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
    """On a worker: its parent, whether the server's preload ran in what it was forked from,
    the environment its process started with, how it hashes a string."""
    booted = sys.modules.get("fmionnx.backends.sweep.workerboot")
    started = Path("/proc/self/environ").read_bytes().split(b"\0")
    return {
        "pid": os.getpid(),
        "parent": os.getppid(),
        "booted": booted is not None and booted.booted(),
        "started_with": dict(v.decode().split("=", 1) for v in started if b"=" in v),
        "hash": hash("fmionnx"),
    }


def _hash_with_dasks_seed() -> int:
    probe = [sys.executable, "-c", "print(hash('fmionnx'))"]
    env = {**os.environ, "PYTHONHASHSEED": DASK_HASH_SEED}
    return int(subprocess.run(probe, env=env, capture_output=True, check=True).stdout)


def test_forked_workers_are_the_servers_children_with_dasks_budget_and_ctrl_c_ignored(
    forked: None,
) -> None:
    import cloudpickle

    from fmionnx.backends.sweep.engine import open_client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import us
    budget = pre_spawn_environment()
    assert budget["OMP_NUM_THREADS"] == os.environ.get("OMP_NUM_THREADS", "1")
    assert budget["PYTHONHASHSEED"] == os.environ.get("PYTHONHASHSEED", DASK_HASH_SEED)
    with open_client(workers=2) as client:
        client.wait_for_workers(2)
        facts = client.run(_worker_facts)
        servers = {f["parent"] for f in facts.values()}
        assert len(servers) == 1
        assert os.getpid() not in servers
        (server,) = servers
        assert "multiprocessing.forkserver" in command_line(server)
        hashed = _hash_with_dasks_seed()
        for fact in facts.values():
            assert fact["booted"]  # the preload ran (SIGINT ignored, the imports done)
            assert {k: fact["started_with"].get(k) for k in budget} == budget
            assert "MALLOC_TRIM_THRESHOLD_" not in fact["started_with"]  # fmionnx's setting
            assert fact["hash"] == hashed  # as a spawned worker hashes

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


def _zygote_facts(fmu: str) -> dict[str, Any]:
    """On a worker: its zygote (forked as the worker started), then the same after a run of
    an isolated FMU in this worker (its child forked by that zygote)."""
    from fmionnx.runtime.isolated import launcher

    first = launcher.zygote_pid()
    facts: dict[str, Any] = {"worker": os.getpid(), "zygote": first}
    if first is not None:
        status = Path(f"/proc/{first}/status").read_text()
        facts["parent"] = int(status.split("PPid:")[1].split()[0])
        facts["threads"] = int(status.split("Threads:")[1].split()[0])
        facts["fds"] = len(list(Path(f"/proc/{first}/fd").iterdir()))
        facts["cores"] = sorted(os.sched_getaffinity(first))
        facts["worker_cores"] = sorted(os.sched_getaffinity(0))
        facts["same_program"] = (
            Path(f"/proc/{first}/cmdline").read_bytes() == Path("/proc/self/cmdline").read_bytes()
        )
    folder = Path(fmu).parent
    system = folder / f"zygote-{os.getpid()}.yaml"
    system.write_text(
        "fmionnx: 1\nname: one\nrun: {stop: 0.05, step: 0.01}\n"
        f"components:\n  gain: {{kind: fmu, path: {fmu}}}\n",
        encoding="utf-8",
    )
    result = fmionnx.load(system).run(isolate="fmus")
    facts["ran"] = len(result.time)
    facts["zygote_after"] = launcher.zygote_pid()
    return facts


def test_each_forked_worker_forks_its_isolated_childrens_zygote_as_it_starts(
    forked: None, tmp_path: Path
) -> None:
    """A zygote started as a new interpreter costs about 0.45 s of CPU per worker; forked
    from the worker as it starts it is warm at once: the worker's own program, one thread,
    only its socket and the standard descriptors, and the zygote the worker's isolated
    children come from."""
    import shutil

    import cloudpickle

    from fmionnx.backends.sweep.engine import open_client
    from tests.conftest import build_fixture_fmu

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    fmu = tmp_path / "Gain.fmu"
    shutil.copy(build_fixture_fmu("Gain"), fmu)
    with open_client(workers=2) as client:
        client.wait_for_workers(2)
        facts = client.run(_zygote_facts, str(fmu))
        for fact in facts.values():
            assert fact["zygote"] is not None
            assert fact["parent"] == fact["worker"]
            assert fact["same_program"]  # a fork, not `python -m ...zygote`
            assert fact["threads"] == 1
            # stdin, stdout, stderr, its socket (and its signal wake-up pipe once it serves):
            # nothing of the nanny's, which would hide the worker's death from it
            assert fact["fds"] in (4, 6)
            assert fact["cores"] == fact["worker_cores"]  # pinned with its worker
            assert fact["ran"] == 6
            assert fact["zygote_after"] == fact["zygote"]  # the child came from it
        # A worker killed outright: its zygote sees its socket close and ends (its children
        # and what their models started with it).
        killed = next(iter(facts.values()))
        os.kill(killed["worker"], signal.SIGKILL)
        deadline = time.monotonic() + 30
        while Path(f"/proc/{killed['zygote']}").exists():
            assert time.monotonic() < deadline, "the zygote outlived its worker"
            time.sleep(0.05)


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
        "import signal, sys\n"
        "import fmionnx.backends.sweep.workerboot as boot\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler,"
        " 'distributed' in sys.modules, boot.booted())\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "False", "False"]


def test_the_budget_is_dasks_with_the_users_configuration_and_variables(tmp_path: Path) -> None:
    probe = (
        "from fmionnx.backends.sweep.workerfork import pre_spawn_environment\n"
        "print(sorted(pre_spawn_environment().items()))\n"
    )
    env = {
        **{
            k: v
            for k, v in os.environ.items()
            if not k.startswith(("OMP_", "MKL_", "DASK_", "PYTHONHASHSEED"))
        },
        "DASK_CONFIG": str(tmp_path),  # the user's Dask configuration
        "OPENBLAS_NUM_THREADS": "2",  # set in the environment: kept, as the nanny keeps it
    }
    (tmp_path / "dask.yaml").write_text(
        "distributed:\n  nanny:\n    pre-spawn-environ:\n      MKL_NUM_THREADS: 3\n", "utf-8"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True
    )
    expected = [
        ("MKL_NUM_THREADS", "3"),
        ("OMP_NUM_THREADS", "1"),
        ("OPENBLAS_NUM_THREADS", "2"),
        ("PYTHONHASHSEED", DASK_HASH_SEED),
    ]
    assert done.stdout.strip() == str(expected)


def test_the_command_forks_its_workers_and_leaves_nothing_in_the_temporary_folder(
    write_study: WriteStudy, tmp_path: Path, short_tmpdir: Path
) -> None:
    """``fmionnx sweep`` (the whole process) starts the server: its workers are its children,
    not the command's; its socket's folder is a scratch folder, gone with the command. (The
    temporary folder is a short path: a socket's is limited to 107 bytes, and under a longer
    one the workers are spawned.)"""
    study = write_study(GRID.replace("gain.k: [0.5, 2, 3]", "gain.k: [0.5, 2, 3, 4, 5, 6, 7]"))
    env = {**os.environ, "TMPDIR": str(short_tmpdir)}
    command = [sys.executable, "-m", "fmionnx", "sweep", str(study), "--out", str(tmp_path / "o")]
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
    assert list(short_tmpdir.iterdir()) == []


def test_the_server_ends_without_tearing_down_its_interpreter() -> None:
    """Torn down, the server held the command's standard output for 0.1-0.15 s after the
    command ended (a caller reading it waited): it leaves from an exit hook, before the
    teardown and before the hooks registered ahead of it."""
    probe = (
        "import atexit, signal\n"
        "atexit.register(print, 'torn down')\n"  # runs after boot's hook, if ever
        "from fmionnx.backends.sweep import workerboot\n"
        "workerboot.boot()\n"
        "print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN, workerboot.booted())\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True"]


def _is_fork_server(pid: int) -> bool:
    try:
        return "multiprocessing.forkserver" in command_line(pid)
    except OSError:  # ended meanwhile
        return False
