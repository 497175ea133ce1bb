"""An FMU whose shared library does not load is a fault of its component, named by the file's
place in the FMU; loading never moves the process's working folder (fmionnx.kinds.fmu.loading)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core import codes
from fmionnx.core.errors import ModelError, RunError
from fmionnx.kinds.fmu.loading import load_library
from fmionnx.runtime.result import RunStatus

LIBRARY = "binaries/linux64/Gain.so"


def _with_library(fmu: Path, content: bytes, target: Path) -> Path:
    """A copy of ``fmu`` whose shared library is ``content``."""
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w") as copy:
        for name in source.namelist():
            copy.writestr(name, content if name == LIBRARY else source.read(name))
    return target


@pytest.fixture
def unloadable(fixture_fmu, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A Gain FMU whose library is not a shared library at all; the test runs in tmp_path."""
    monkeypatch.chdir(tmp_path)
    return _with_library(fixture_fmu("Gain"), b"not an ELF file", tmp_path / "Broken.fmu")


def test_a_library_that_does_not_load_is_a_fault_and_the_working_folder_stays(
    unloadable: Path, tmp_path: Path
) -> None:
    result = fmionnx.load(unloadable).run(isolate="none", stop_time=0.1)
    assert result.status is RunStatus.FAULT
    assert isinstance(result.error, RunError)
    message = str(result.error)
    assert message.startswith("component `Broken` at t=0 s: its shared library does not load: ")
    assert f"{LIBRARY}: " in message  # its place in the FMU ...
    assert "fmionnx-" not in message  # ... not the scratch folder it was unpacked into
    assert Path.cwd() == tmp_path  # fmpy left the process in the (removed) scratch folder


@pytest.mark.parametrize("isolate", ["none", "default"])
def test_the_command_reports_the_library_without_a_traceback(
    unloadable: Path, tmp_path: Path, isolate: str
) -> None:
    """Alone (``--isolate none``: in this process) and in a system, isolated by default."""
    if isolate == "none":
        command = [str(unloadable), "--isolate", "none"]
    else:
        system = tmp_path / "system.yaml"
        system.write_text(
            "fmionnx: 1\nname: s\nrun: {stop: 0.1, step: 0.01}\n"
            f"components:\n  broken: {{kind: fmu, path: {unloadable.name}}}\n",
            encoding="utf-8",
        )
        command = [str(system)]
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "run", *command, "-o", "out"],
        capture_output=True, text=True, timeout=120, check=False,
        env={**os.environ, "COLUMNS": "200"},
    )  # fmt: skip
    assert done.returncode == 1, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert "its shared library does not load: binaries/linux64/Gain.so:" in done.stderr
    assert (tmp_path / "out" / "run.json").is_file()


def test_loads_in_threads_take_turns_and_leave_the_working_folder(tmp_path: Path) -> None:
    """fmpy's way of loading, as a stand-in for the peer: it moves the whole process into the
    library's folder and back, with time between (the GIL released in ``dlopen``)."""
    home = tmp_path / "home"
    home.mkdir()
    inside: list[tuple[Path, Path]] = []

    def fmpy_like(library_dir: Path) -> Path:
        work_dir = Path.cwd()
        os.chdir(library_dir)
        time.sleep(0.01)
        inside.append((library_dir, Path.cwd()))  # where the library was loaded from
        os.chdir(work_dir)
        return library_dir

    folders = [tmp_path / f"lib{i}" for i in range(6)]
    for folder in folders:
        folder.mkdir()
    before = Path.cwd()
    os.chdir(home)
    try:
        threads = [
            threading.Thread(target=load_library, args=("c", folder, lambda f=folder: fmpy_like(f)))
            for folder in folders
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert Path.cwd() == home
    finally:
        os.chdir(before)
    assert sorted(inside) == [(folder, folder) for folder in folders]


def test_a_load_that_fails_midway_puts_the_working_folder_back(tmp_path: Path) -> None:
    library_dir = tmp_path / "lib"
    library_dir.mkdir()
    before = Path.cwd()

    def dlopen() -> None:
        raise OSError(f"{library_dir}/binaries/x.so: wrong ELF class: ELFCLASS32")

    def fails_inside() -> None:
        os.chdir(library_dir)
        try:
            dlopen()
        except OSError as exc:  # fmpy wraps it in a bare Exception
            raise Exception("Failed to load shared library") from exc  # noqa: TRY002

    with pytest.raises(RunError) as raised:
        load_library("c", library_dir, fails_inside)
    assert Path.cwd() == before
    assert str(raised.value) == (
        "component `c` at t=0 s: its shared library does not load: binaries/x.so: wrong ELF "
        "class: ELFCLASS32 (a library built for another platform, damaged, or needing a "
        "library this machine does not have)"
    )


def test_fmionnx_own_errors_on_the_way_pass_unchanged(tmp_path: Path) -> None:
    """The check that the library lies inside the FMU (E017) runs as fmpy's object is made."""
    problem = ModelError(codes.UNSAFE_ARCHIVE, "outside")

    def refused() -> None:
        raise problem

    with pytest.raises(ModelError) as raised:
        load_library("c", tmp_path, refused)
    assert raised.value is problem


def test_a_removed_working_folder_is_said_so(tmp_path: Path, monkeypatch) -> None:
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    with pytest.raises(RunError, match="this process's working folder was removed"):
        load_library("c", tmp_path, lambda: None)


def test_a_child_forked_while_a_thread_loads_can_load(tmp_path: Path) -> None:
    """The guardian forks the run: another thread of the parent may be inside a load then."""
    inside, release = threading.Event(), threading.Event()

    def slow() -> None:
        inside.set()
        release.wait(30)

    loader = threading.Thread(target=load_library, args=("c", tmp_path, slow))
    loader.start()
    try:
        assert inside.wait(30)
        pid = os.fork()
        if pid == 0:  # the child: its load must not wait for the parent's thread
            signal.alarm(10)
            load_library("c", tmp_path, lambda: None)
            os._exit(0)
        _, status = os.waitpid(pid, 0)
    finally:
        release.set()
        loader.join()
    assert os.waitstatus_to_exitcode(status) == 0
