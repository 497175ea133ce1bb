"""Shared fixtures: no network, real models built from the repository's own sources."""

from __future__ import annotations

import fcntl
import hashlib
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"
BUILT_MODELS = REPO / "build" / "models"
FIXTURE_BUILD = REPO / "build" / "test-fixtures"


def worker_group(nodeid: str) -> str:
    """The pytest-xdist work unit a test belongs to (``make test``): every test that starts
    Zenoh processes runs on one worker, every test that starts DDS processes on one worker, one
    after the other (two ROS 2 runs at once would see each other's topics if their random
    domains met), and any other test with the rest of its file (its module fixtures are made
    once)."""
    path = nodeid.split("::", 1)[0]
    if "zenoh" in path:
        return "zenoh"
    if "ros2" in path:  # tests/ros2/ and the ROS 2 benchmarks' quick runs
        return "dds"
    return path


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A test marked ``ros2`` lives where :func:`worker_group` puts it with the other ROS 2
    tests: the scheduler sees only test ids, not markers."""
    astray = [
        item.nodeid
        for item in items
        if item.get_closest_marker("ros2") is not None
        and worker_group(item.nodeid) not in {"dds", "zenoh"}
    ]
    if astray:
        msg = f"tests marked ros2 outside a path naming ros2 (their worker group): {astray}"
        raise pytest.UsageError(msg)


def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """``--dist loadscope`` with :func:`worker_group` as the scope.

    xdist's own ``loadgroup`` renames each test's ``nodeid`` after its ``xdist_group`` marker,
    which pytest 9.2 no longer lets it do (the id is derived, not stored): the groups were
    silently ignored and the DDS tests ran on both workers. The scope here is computed from
    the nodeid the controller is given, whatever pytest does with it.
    """
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):  # type: ignore[misc]
        def _split_scope(self, nodeid: str) -> str:
            return worker_group(nodeid)

    return GroupScheduling(config, log)


@pytest.fixture(autouse=True)
def _no_network(monkeypatch: pytest.MonkeyPatch) -> None:
    """Tests never reach beyond this machine: only loopback and local sockets are allowed."""
    real_connect = socket.socket.connect

    def guarded(self: socket.socket, address: object) -> object:
        host = address[0] if isinstance(address, tuple) else None
        if host is not None and not str(host).startswith(("127.", "::1", "localhost")):
            msg = f"test tried to reach {address}"
            raise RuntimeError(msg)
        return real_connect(self, address)  # type: ignore[arg-type]

    monkeypatch.setattr(socket.socket, "connect", guarded)


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts with an empty cache folder of its own (compiled systems, unpacked SSP
    archives): the caches stay on, as users have them, and one test's entries never serve
    another's compile. Tests that need another folder set ``FMIONNX_CACHE`` themselves."""
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path_factory.mktemp("cache")))


def drop_worker_state() -> None:
    """Drop what a study's worker keeps in this process: its idle isolated children (and their
    blocking on the pipe at once) and its FMU libraries (issue 32)."""
    proxy = sys.modules.get("fmionnx.runtime.isolated.proxy")
    if proxy is not None:
        pool = proxy._children.clear()
        if pool is not None:
            pool.close()
        proxy._children_spin[0] = True
    libraries = sys.modules.get("fmionnx.kinds.fmu.libraries")
    if libraries is not None:
        libraries.stop_keeping_libraries()


@pytest.fixture(autouse=True)
def _no_worker_state_left() -> Iterator[None]:
    """A test that runs a study's batch in this process makes it a study's worker: a later
    test's isolated run would then be served by a kept child instead of starting its own.
    What a worker keeps is dropped after each test."""
    yield
    drop_worker_state()


#: The signals whose handling a test may change in this process (a command run in-process
#: ignores them once it was stopped: ``stop_on_signals(process_ends=True)``).
HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@pytest.fixture(autouse=True)
def _signals_as_they_were() -> Iterator[None]:
    """Each test ends with this process's signal handlers as it found them.

    A signal a process ignores is ignored by every program it starts (a Rerun server with
    SIGINT ignored lets its Ctrl-C pass and never ends), and a command run in-process that
    was stopped leaves its stop signals ignored.
    """
    before = {signum: signal.getsignal(signum) for signum in HANDLED_SIGNALS}
    yield
    for signum, handler in before.items():
        if signal.getsignal(signum) is not handler and handler is not None:
            signal.signal(signum, handler)


def finish(process: subprocess.Popen[str], timeout: float) -> tuple[str, str]:
    """``process.communicate(timeout)``, killing the process if it does not end in time.

    A test that gives up on a hung run must not leave it behind: a leftover process would
    load the machine (and hold its files) for every test after it.
    """
    try:
        return process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        _, err = process.communicate()
        said = f" stderr:\n{err[-4000:]}" if err is not None else ""  # None: not a pipe
        pytest.fail(f"the process did not end within {timeout} s; killed.{said}")


def end_process(process: subprocess.Popen[Any] | None) -> None:
    """Kill ``process`` if it still runs, and always reap it and close its pipes.

    A test's ``finally`` that only reaps a process still running leaves the pipes of one that
    ended by itself open: the garbage collector closes them later, with a ResourceWarning
    that fails whichever test of the worker happens to be running then.
    """
    if process is None:
        return
    if process.poll() is None:
        process.kill()
    process.communicate(timeout=30)


def _tree_hash(folder: Path) -> str:
    digest = hashlib.sha256()
    for file in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(file.relative_to(folder).as_posix().encode())
        digest.update(file.read_bytes())
    return digest.hexdigest()[:16]


def build_fixture_fmu(name: str) -> Path:
    """Build ``tests/fixtures/fmus/<name>`` into a binary FMU, cached by source hash."""
    from fmionnx.kinds.fmu.build import build_fmu

    source = FIXTURES / "fmus" / name
    digest = _tree_hash(source)
    output = FIXTURE_BUILD / f"{name}-{digest}.fmu"
    if output.exists():
        return output
    FIXTURE_BUILD.mkdir(parents=True, exist_ok=True)
    with (FIXTURE_BUILD / f".{name}.lock").open("w") as lock:  # test workers build it once
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not output.exists():
            build_fmu(source, output)  # written atomically
    return output


@pytest.fixture(scope="session")
def fixture_fmu() -> object:
    """Callable fixture: ``fixture_fmu("Gain")`` -> path of the built test FMU."""
    return build_fixture_fmu


def built_model(name: str) -> Path:
    """A model built by ``make models`` (``build/models/<name>``); skips nothing: it must exist."""
    path = BUILT_MODELS / name
    if not path.exists():
        msg = f"{path} is missing: run `make models` first (make test does)"
        raise FileNotFoundError(msg)
    return path


def let_files_settle() -> None:
    """Wait out the compile cache's margin: a compile that begins within
    ``CHANGE_MARGIN_NS`` of a change to a file it reads is not kept (the file may have
    changed while it was read), so a test that writes a model and expects its compile to be
    read back lets it settle first."""
    from fmionnx.pipeline.compilecache import CHANGE_MARGIN_NS

    time.sleep(2 * CHANGE_MARGIN_NS / 1e9)


def cli(*args: str) -> tuple[int, str]:
    """Run ``fmionnx ARGS`` in-process: the exit code and the output with whitespace runs
    folded (messages wrap at the terminal's width); a traceback fails the test."""
    from typer.testing import CliRunner

    from fmionnx.cli import app

    result = CliRunner().invoke(app, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in result.output
    return result.exit_code, " ".join(result.output.split())
