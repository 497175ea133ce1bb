"""A scheduler and a worker started as separate processes (``dask scheduler``, ``dask worker``),
in a working folder of their own, run a study whose model files are no longer where the
system was compiled: the study ships what its cases need, by content hash."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

import fmionnx
from fmionnx.backends.sweep import engine
from fmionnx.backends.sweep.case import CaseOutcome, Job
from fmionnx.backends.sweep.engine import open_client, run_study
from fmionnx.backends.sweep.models import STORE_NAME, pack_models
from fmionnx.compile.systemfile import has_model_file
from fmionnx.pipeline.study import run_study_case
from fmionnx.pipeline.sweep import plan_study
from tests.sweep.conftest import WriteStudy

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector
#: (a ResourceWarning raised while collecting, so not attributable to a line of ours).
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


STUDY = """\
fmionnx: 1
system: system.yaml
parameters:
  gain.k: [1, 2]
  integ.x0: [0, 0.5]
metrics:
  y_end: final(gain.y)
"""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _start(args: list[str], cwd: Path, log: Path) -> subprocess.Popen[bytes]:
    with log.open("wb") as stream:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args],
            cwd=cwd,
            stdout=stream,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: stopped with everything it started
        )


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=15)


@pytest.fixture
def remote(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """The scheduler's address and the worker's working folder (far from the study); the
    worker runs one thread unless the test is parametrized indirectly with another count."""
    with _cluster(
        tmp_path, ["--host", "127.0.0.1", "--nthreads", str(getattr(request, "param", 1))]
    ) as found:
        yield found


@contextmanager
def _cluster(tmp_path: Path, worker_args: list[str]) -> Iterator[tuple[str, Path]]:
    """A scheduler and one worker started with ``worker_args``, as :func:`remote` gives them."""
    home = tmp_path / "worker-home"
    home.mkdir()
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = []
    try:
        processes.append(
            _start(
                ["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                home,
                tmp_path / "scheduler.log",
            )
        )
        processes.append(
            _start(
                [
                    "worker", address, *worker_args, "--nworkers", "1",
                    "--no-dashboard", "--local-directory", str(home / "local"),
                ],
                home,
                tmp_path / "worker.log",
            )
        )  # fmt: skip
        deadline = time.monotonic() + 90
        while True:
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                if time.monotonic() > deadline or processes[0].poll() is not None:
                    raise
                time.sleep(0.2)
        with open_client(address) as client:
            client.wait_for_workers(1, timeout=90)
        yield address, home
    finally:
        # The clients studies kept for it first: left open they would try to reconnect in the
        # background for the rest of the worker's tests, drawing from the global ``random``,
        # which Hypothesis then reports as a flaky property test (as the ``cluster`` fixture).
        engine.close_shared_clients()
        for process in reversed(processes):
            _stop(process)


@pytest.mark.parametrize("inline_bytes", [engine.INLINE_BYTES, 0], ids=["inside", "as-tasks"])
def test_models_travel_to_a_remote_worker_by_hash(
    write_study: WriteStudy,
    remote: tuple[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    inline_bytes: int,
) -> None:
    """Small models travel inside every task, larger ones as tasks of their own (once per
    worker): either way the worker finds them by hash in its own store."""
    monkeypatch.setattr(engine, "INLINE_BYTES", inline_bytes)
    address, home = remote
    study = write_study(STUDY)
    plan, _ = plan_study(study)
    packed = pack_models(plan.system)
    assert set(packed) == {
        c.interface.content_hash for c in plan.system.components if has_model_file(c)
    }
    shutil.move(study.parent / "models", tmp_path / "elsewhere")  # the compiled paths are gone
    for component in plan.system.components:
        assert not has_model_file(component) or not component.path.exists()
    outcomes: list[CaseOutcome] = []
    with open_client(address) as client:
        run_study(
            client,
            plan,
            plan.cases,
            Job(plan.metrics, ("fmus",), 60.0),
            outcomes.append,
            run_study_case,
            packed,
        )
    by_id = {o.id: o for o in outcomes}
    assert [by_id[c.id].status for c in plan.cases] == ["ok"] * 4, [o.message for o in outcomes]
    assert [by_id[c.id].metrics["y_end"] for c in plan.cases] == pytest.approx([1, 1.5, 2, 3])
    stores = list(home.glob(f"local/**/{STORE_NAME}"))
    assert len(stores) == 1  # the worker's own store, in its own folder
    assert {p.name for p in stores[0].iterdir()} == set(packed)

    # the API and an existing cluster: `fmionnx.sweep(..., scheduler=...)`
    shutil.move(tmp_path / "elsewhere", study.parent / "models")
    table = fmionnx.sweep(study, out=tmp_path / "out", scheduler=address)
    assert list(table["status"]) == ["ok"] * 4
    assert list(table["y_end"]) == pytest.approx([1, 1.5, 2, 3])


MANY = """\
fmionnx: 1
system: system.yaml
isolate: [{isolate}]
parameters:
  gain.k: {{range: {{start: 0.5, stop: 2, num: 6}}}}
  integ.x0: [0, 0.25, 0.5, 1]
metrics:
  y_end: final(gain.y)
"""


@pytest.mark.parametrize("remote", [4], indirect=True)
@pytest.mark.parametrize("isolate", ["none", "fmus"])
def test_a_worker_of_several_threads_runs_its_cases_side_by_side_alike(
    write_study: WriteStudy, remote: tuple[str, Path], isolate: str
) -> None:
    """``dask worker`` runs as many threads as cores unless told otherwise: cases then run side
    by side in one process (FMU libraries loaded at once, isolated children forked at once)."""
    address, _ = remote
    study = write_study(MANY.format(isolate=isolate))
    plan, _ = plan_study(study)
    outcomes: list[CaseOutcome] = []
    with open_client(address) as client:
        run_study(client, plan, plan.cases, Job.of(plan), outcomes.append, run_study_case, batch=1)
    assert len(outcomes) == 24
    for case in plan.cases:
        outcome = next(o for o in outcomes if o.id == case.id)
        assert outcome.status == "ok", outcome.message
        values = case.values()
        expected = float(values["gain.k"]) * (float(values["integ.x0"]) + 1)
        assert outcome.metrics["y_end"] == pytest.approx(expected), case


def test_a_worker_with_a_host_name_for_contact_address_still_gets_its_next_tasks(
    write_study: WriteStudy, tmp_path: Path
) -> None:
    """A worker behind NAT or in a container listens on one address and is reached at another
    (``--contact-address``), often a host name. The scheduler knows it by the resolved IP
    address, while a case names its worker as the worker calls itself (the table's column):
    the engine must map that to the scheduler's address before pinning the worker's next
    task to it (a restriction to the host name would name no worker)."""
    port = _free_port()
    contact = f"tcp://localhost:{port}"
    worker_args = ["--listen-address", f"tcp://0.0.0.0:{port}", "--contact-address", contact]
    study = write_study(MANY.format(isolate="none"))
    plan, _ = plan_study(study)
    outcomes: list[CaseOutcome] = []
    with _cluster(tmp_path, worker_args) as (address, _), open_client(address) as client:
        known = set(client.scheduler_info()["workers"])
        run_study(client, plan, plan.cases, Job.of(plan), outcomes.append, run_study_case, batch=1)
        cluster = engine._Cluster(client)
    assert known == {f"tcp://127.0.0.1:{port}"}
    assert len(outcomes) == 24
    assert {o.worker for o in outcomes} == {contact}
    assert {cluster.address_of(o.worker) for o in outcomes} == known
