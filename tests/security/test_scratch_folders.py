"""No folder an FMU was unpacked into survives its process, however the process ends.

Runs unpack every FMU into a scratch folder. Normal ends and faults remove it (terminate);
any other exit of the interpreter removes it through ``atexit``; a process killed outright
(SIGKILL, a native crash) cannot, so the next fmionnx process removes what it left.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core.scratch import PREFIX, sweep_stale
from fmionnx.runtime.result import RunStatus
from tests.conftest import build_fixture_fmu


def _child(code: str, tmp: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "TMPDIR": str(tmp)}
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        timeout=90,
        check=False,
    )


def _scratch_folders(tmp: Path) -> list[Path]:
    return sorted(p for p in tmp.iterdir() if p.name.startswith(PREFIX))


@pytest.fixture
def tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A private temporary folder for this process and its children."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_a_killed_run_leaves_a_folder_that_the_next_process_removes(tmp: Path) -> None:
    fmu = build_fixture_fmu("Integrator")
    killed = _child(
        "import os, signal, fmionnx\n"
        f"system = fmionnx.load({str(fmu)!r}, step=0.01)\n"
        "system.run(isolate='none', stop_time=1.0,\n"
        "           progress=lambda *a: os.kill(os.getpid(), signal.SIGKILL))\n",
        tmp,
    )
    assert killed.returncode == -9, killed.stderr
    left = _scratch_folders(tmp)
    assert len(left) == 1  # the unpacked FMU of the killed run
    assert (left[0] / "modelDescription.xml").is_file()
    after = _child(
        f"import fmionnx\nfmionnx.load({str(fmu)!r}, step=0.01).run(isolate='none', stop_time=0.05)\n",
        tmp,
    )
    assert after.returncode == 0, after.stderr
    assert _scratch_folders(tmp) == []


def test_an_exit_without_terminate_removes_the_folder(tmp: Path) -> None:
    ended = _child(
        "from fmionnx.core.scratch import make_scratch\n"
        "folder = make_scratch('model')\n"
        "(folder / 'lib.so').write_bytes(b'x')\n"
        "raise SystemExit(3)\n",
        tmp,
    )
    assert ended.returncode == 3, ended.stderr
    assert _scratch_folders(tmp) == []


def test_completed_and_faulted_runs_leave_nothing(tmp: Path) -> None:
    done = fmionnx.load(build_fixture_fmu("Integrator"), step=0.01).run(
        isolate="none", stop_time=0.1
    )
    assert done.status is RunStatus.COMPLETED
    faulted = fmionnx.load(build_fixture_fmu("Faulty"), step=0.01).run(
        isolate="none", stop_time=1.0
    )
    assert faulted.status is RunStatus.FAULT
    assert _scratch_folders(tmp) == []


def test_folders_of_live_processes_and_of_other_names_are_kept(tmp: Path) -> None:
    mine = tmp / f"{PREFIX}{os.getppid()}-model-abc"  # the parent (pytest's runner) lives
    other = tmp / f"{PREFIX}ros2-abc"
    for folder in (mine, other):
        folder.mkdir()
    assert sweep_stale(tmp) == []
    assert mine.is_dir()
    assert other.is_dir()


def test_a_folder_whose_owner_lives_in_another_pid_namespace_is_kept(tmp: Path) -> None:
    """The process id in the name means nothing there; the owner's lock decides."""
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys\n"
            "from fmionnx.core.scratch import make_scratch\n"
            "print(make_scratch('model'), flush=True)\n"
            "sys.stdin.read()\n",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "TMPDIR": str(tmp)},
    )
    try:
        assert holder.stdout is not None
        made = Path(holder.stdout.readline().strip())
        elsewhere = made.rename(tmp / f"{PREFIX}999999999-model-abc")  # an id no process has
        assert sweep_stale(tmp) == []
        assert elsewhere.is_dir()
    finally:
        holder.communicate("", timeout=30)
    assert sweep_stale(tmp) == [elsewhere]  # the owner is gone now
