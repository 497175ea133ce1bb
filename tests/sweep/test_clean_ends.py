"""A study stopped by Ctrl-C or SIGTERM ends cleanly and leaves nothing behind.

Ctrl-C went to the local cluster's workers too (a terminal signals its whole process group):
each died inside Dask's shutdown and printed tracebacks, five in all. SIGTERM (a cancelled CI
job) killed the driver without a word. Every study left ``dask-scratch-space`` in the
temporary folder, and a stopped one the unpacked FMUs of the cases it cut short. Now the
workers leave Ctrl-C to the driver, SIGTERM and SIGHUP stop a study as Ctrl-C does (exit
128 + signal), and the temporary folder is as it was. (``--resume`` finishing such a study:
``tests/sweep/test_resume_determinism.py``.)
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import finish
from tests.processes import child_pids, command_line, group_members

SYSTEM = """\
fmionnx: 1
name: gain
run: {{stop: 6, step: 0.0001}}
components:
  gain: {{kind: fmu, path: {gain}, parameters: {{u: 1, v: [0, 0, 0]}}}}
"""
#: Cases of the study, of about 0.4 s each here (``stop: 6``): a Ctrl-C sent once the first
#: record is there lands seconds before the last. Cases of 0.1 s all finished first now and
#: then in loaded CI runs (their batches hold several cases: docs/sweep.md).
CASES = 16
STUDY = f"""\
fmionnx: 1
system: system.yaml
parameters:
  gain.k: {{range: {{start: 1, stop: {CASES}, num: {CASES}}}}}
metrics:
  y_end: final(gain.y)
"""


@pytest.fixture
def project(tmp_path: Path, fixture_fmu, short_tmpdir: Path) -> Path:
    """The study, and its temporary folder (``tmp``): a link to a folder of a short path
    (``short_tmpdir``), as a user's is."""
    (tmp_path / "system.yaml").write_text(SYSTEM.format(gain=fixture_fmu("Gain")), "utf-8")
    (tmp_path / "study.yaml").write_text(STUDY, "utf-8")
    (tmp_path / "tmp").symlink_to(short_tmpdir)
    return tmp_path


def _sweep(project: Path, *extra: str, fork: bool = True) -> subprocess.Popen[str]:
    """``fmionnx sweep`` in a session of its own (a terminal's process group), with its own
    temporary folder and Ctrl-C delivered as a terminal delivers it; its workers forked
    from its fork server, or spawned by Dask's nanny (``fork=False``)."""
    env = {**os.environ, "TMPDIR": str((project / "tmp").resolve())}
    env["FMIONNX_FORK_WORKERS"] = "1" if fork else "0"
    return subprocess.Popen(
        [sys.executable, "-m", "fmionnx", "sweep", "study.yaml", "--out", "out",
         "--workers", "2", *extra],
        cwd=project, env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # noqa: PLW1509
    )  # fmt: skip


def _after_the_first_case(project: Path, process: subprocess.Popen[str]) -> None:
    records = project / "out" / "records"
    deadline = time.monotonic() + 180
    while not (records.is_dir() and any(records.glob("*.json"))):
        if process.poll() is not None or time.monotonic() > deadline:
            out, err = finish(process, 30)
            pytest.fail(f"no case finished: {out}{err}")
        time.sleep(0.1)


@pytest.mark.parametrize("fork", [True, False], ids=["forked", "spawned"])
def test_ctrl_c_stops_the_study_cleanly_and_keeps_its_records(project: Path, fork: bool) -> None:
    # One case per task: its record is written as it ends. Batched, the study's first two
    # tasks held 8 cases each (an even share per worker), and under the suite's load both
    # ended before the Ctrl-C that followed the first record landed: all 16 were recorded.
    process = _sweep(project, "--batch", "1", fork=fork)
    _after_the_first_case(project, process)
    os.killpg(process.pid, signal.SIGINT)  # as a terminal does: every process of the group
    out, err = finish(process, 120)
    assert process.returncode == 130, err
    assert "interrupted by SIGINT: the finished cases are in out; `--resume` runs the rest" in out
    assert "Traceback" not in err, err[-4000:]  # the whole traceback, when one came
    recorded = len(list((project / "out" / "records").glob("*.json")))
    # Stopped before its last case, as a rule; under a loaded suite the driver took in the
    # first results late, all at once, and every case was done by the Ctrl-C (seen once).
    assert 1 <= recorded <= CASES, (out, err)
    assert list((project / "tmp").iterdir()) == []  # no dask-scratch-space, no unpacked FMU


def test_sigterm_to_the_driver_stops_the_study_as_ctrl_c_does(project: Path) -> None:
    process = _sweep(project)
    _after_the_first_case(project, process)
    process.send_signal(signal.SIGTERM)
    out, err = finish(process, 120)
    assert process.returncode == 143, err
    assert "interrupted by SIGTERM" in out
    assert "Traceback" not in err, err[-4000:]  # the whole traceback, when one came
    assert list((project / "tmp").iterdir()) == []


def test_a_killed_fork_server_takes_its_workers_and_the_study_runs_their_cases_again(
    project: Path,
) -> None:
    """The workers are the fork server's children, and a nanny learns from the server that
    its worker ended: killed alone (an out-of-memory killer), the server told every nanny
    so while the workers ran on, the nannies started new ones beside them and the study
    could wait for ever. The workers now end with it; new ones are forked from a new server
    and the study finishes every case."""
    process = _sweep(project)
    _after_the_first_case(project, process)
    servers = [pid for pid in child_pids(process.pid) if _is_fork_server(pid)]
    assert len(servers) == 1, "the command has no fork server"
    workers = child_pids(servers[0])
    assert workers, "the fork server has no worker"
    os.kill(servers[0], signal.SIGKILL)
    _, err = finish(process, 180)
    assert process.returncode == 0, err
    assert "Traceback" not in err, err[-4000:]  # the whole traceback, when one came
    assert "ERROR" not in err  # the scheduler's reports of lost tasks: the study says it
    records = sorted((project / "out" / "records").glob("*.json"))
    assert len(records) == CASES
    assert all(json.loads(r.read_text("utf-8"))["status"] == "ok" for r in records)
    for worker in workers:  # gone with their server
        assert not Path(f"/proc/{worker}").exists() or _zombie(worker)


def _is_fork_server(pid: int) -> bool:
    try:
        return "multiprocessing.forkserver" in command_line(pid)
    except OSError:  # ended meanwhile
        return False


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def _semaphores_once_mapped(process: subprocess.Popen[str]) -> set[Path]:
    """The semaphores ``process``'s group maps by name, once it maps one: under a loaded
    suite's CPU the first record came (once) before any worker had opened one by its name,
    the kill left none and the premise check below failed."""
    deadline = time.monotonic() + 60
    while not (ours := _semaphores_of_group(process.pid)):
        if process.poll() is not None or time.monotonic() > deadline:
            out, err = finish(process, 30)
            pytest.fail(f"the study's processes mapped no semaphore by name: {out}{err}")
        time.sleep(0.05)
    return ours


def _until_gone(pgid: int) -> None:
    """Wait for every process of group ``pgid`` to end: a killed process keeps its mappings
    until the kernel has torn it down, which a loaded machine can take longer to do than
    the half second this test once slept."""
    deadline = time.monotonic() + 30
    while group_members(pgid):
        assert time.monotonic() < deadline, f"group {pgid} outlived SIGKILL by 30 s"
        time.sleep(0.05)


def _unmapped_semaphores() -> set[Path]:
    from fmionnx.backends.sweep.leftovers import SHM, _mapped

    mapped = _mapped(Path("/proc"), SHM, os.getuid())
    return {path for path in SHM.glob("sem.mp-*") if path.name not in mapped}


def _semaphores_of_group(pgid: int) -> set[Path]:
    """The semaphores that processes of group ``pgid`` map by their names.

    A process that opened a semaphore by its name maps it so; its creator maps the temporary
    file ``sem_open`` made it from, so a semaphore just made for a worker about to start
    looks unmapped until the worker opens it. Taking every semaphore that looked unmapped
    after the kill for this study's took such a one of a study of another test worker: its
    age set back an hour below, the next study removed it and that worker's start failed
    (``FileNotFoundError`` unpickling its lock, seen once in a full suite)."""
    from fmionnx.backends.sweep.leftovers import SHM

    found: set[Path] = set()
    for pid in group_members(pgid):
        try:
            maps = Path(f"/proc/{pid}/maps").read_text(errors="replace")
        except OSError:
            continue  # ended while we looked
        for line in maps.splitlines():
            if f"{SHM}/sem.mp-" in line:
                found.add(SHM / line.split(f"{SHM}/", 1)[1].removesuffix(" (deleted)"))
    return found


def test_after_a_study_killed_outright_the_next_one_removes_what_it_left(project: Path) -> None:
    """SIGKILL to the whole group (an out-of-memory killer, a CI timeout) runs no exit code:
    the study's Dask scratch folder and the named semaphores of its workers' resource tracker
    stayed for good. The next study removes them and ``--resume`` finishes the first."""
    # Killed as soon as its processes map a semaphore by name, not after its first record:
    # under a loaded suite the workers opened theirs late (the premise check below failed
    # once), and waited for, the study had finished every case (once), so nothing was left
    # to resume, the resumed study started no cluster and removed nothing.
    process = _sweep(project, "--batch", "1")
    ours = _semaphores_once_mapped(process)
    os.killpg(process.pid, signal.SIGKILL)
    finish(process, 30)
    _until_gone(process.pid)
    left = ours & _unmapped_semaphores()
    assert left, "the killed study left no semaphore: this test's premise is gone"
    assert list((project / "tmp").iterdir()) != []  # the killed study's scratch folder
    long_ago = time.time() - 3600
    for path in left:  # as if the next study ran a while later
        os.utime(path, (long_ago, long_ago))
    done = len(list((project / "out" / "records").glob("*.json")))
    assert done < CASES, "the killed study finished every case: nothing left to resume"
    resumed = _sweep(project, "--resume")
    _, err = finish(resumed, 180)
    assert resumed.returncode == 0, err
    assert len(list((project / "out" / "records").glob("*.json"))) == CASES
    unmapped = _unmapped_semaphores()
    assert [path for path in left if path in unmapped] == []
    assert list((project / "tmp").iterdir()) == []


def test_while_a_local_cluster_lives_its_closed_connections_say_nothing() -> None:
    """A case's result arriving as the stopped study's cluster closed made Dask's tracking of
    it log a ``CommClosedError`` traceback through tornado (one run in ten of the Ctrl-C test
    above on a fast machine). While a local cluster of a study lives and closes, those
    reports are dropped, others kept; the filter goes with the cluster."""
    import logging

    from distributed.comm.core import CommClosedError

    from fmionnx.backends.sweep import engine

    logger = logging.getLogger("tornado.application")

    def record(error: BaseException) -> logging.LogRecord:
        return logger.makeRecord(
            logger.name, logging.ERROR, __file__, 1, "Exception in callback", (),
            (type(error), error, None),
        )  # fmt: skip

    closed = record(CommClosedError("in <TCP (closed)>: Stream is closed"))
    assert logger.filter(closed)
    with engine.open_client(workers=1):
        assert not logger.filter(closed)
        assert logger.filter(record(ValueError("something else")))
    assert logger.filter(closed)


def test_while_a_local_cluster_lives_the_schedulers_reports_of_lost_tasks_say_nothing() -> None:
    """A worker's death made the scheduler log ``ERROR`` lines on the user's terminal (task
    keys, "marked as failed because 1 workers died", "Couldn't gather keys") about what the
    study handles and reports itself. While a local cluster of a study lives, those are
    dropped, the scheduler's other reports kept; the filter goes with the cluster."""
    import logging

    from fmionnx.backends.sweep import engine

    logger = logging.getLogger("distributed.scheduler")

    def record(message: str, *args: object) -> logging.LogRecord:
        return logger.makeRecord(logger.name, logging.ERROR, __file__, 1, message, args, None)

    lost = record("Task %s marked as failed because %d workers died while trying to run it",
                  "fmionnx-case-0000", 1)  # fmt: skip
    gone = record("Couldn't gather keys: %s", {"fmionnx-case-0001": "queued"})
    other = record("Something else went wrong: %s", "here")
    assert logger.filter(lost)
    with engine.open_client(workers=1):
        assert not logger.filter(lost)
        assert not logger.filter(gone)
        assert logger.filter(other)
    assert logger.filter(lost)
