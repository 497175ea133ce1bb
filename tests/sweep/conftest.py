"""Study fixtures: a small FMU-only system (a signal, an Integrator and a Gain test FMU).

``final(gain.y)`` is ``k * (x0 + t_stop)``: every case's metric can be checked against a direct
run of the same system with the same parameters.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

SYSTEM = """\
fmionnx: 1
name: chain
run: {{stop: 1, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{y: {{constant: 1}}}}}}
  integ: {{kind: fmu, path: {integrator}}}
  gain: {{kind: fmu, path: {gain}, parameters: {{v: [0, 0, 0]}}}}
connections:
  - src.y -> integ.u
  - integ.x -> gain.u
checks:
  - name: small
    expect: final(gain.y) < 3
"""

#: Writes ``study.yaml`` (text) beside the chain system (``system.yaml``) and returns its path.
WriteStudy = Callable[[str], Path]


@pytest.fixture
def chain_folder(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    """A folder with the chain system and copies of its two FMUs (``models/``)."""
    import shutil

    models = tmp_path / "models"
    models.mkdir()
    for name in ("Integrator", "Gain"):
        shutil.copy(fixture_fmu(name), models / f"{name}.fmu")
    text = SYSTEM.format(integrator="models/Integrator.fmu", gain="models/Gain.fmu")
    (tmp_path / "system.yaml").write_text(text, encoding="utf-8")
    return tmp_path


@pytest.fixture
def write_study(chain_folder: Path) -> WriteStudy:
    def write(text: str) -> Path:
        path = chain_folder / "study.yaml"
        path.write_text(text, encoding="utf-8")
        return path

    return write


@pytest.fixture(scope="module")
def cluster() -> object:
    """One local Dask cluster (2 worker processes) shared by a module's tests.

    The clients the studies kept for it are closed before it ends: left open, they would try
    to reconnect in the background for the rest of the worker's tests (Dask's backoff draws
    from the global ``random``, which Hypothesis reports as a flaky property test)."""
    from fmionnx.backends.sweep.engine import close_shared_clients, open_client

    with open_client(workers=2) as client:
        yield client.scheduler.address
        close_shared_clients()


@pytest.fixture(autouse=True)
def _collect_garbage() -> object:
    """Collect after each test, so what Dask leaves to the collector is reported (and ignored,
    see the modules' ``pytestmark``) here rather than in whichever test runs next."""
    import gc

    yield
    gc.collect()


@pytest.fixture
def forked(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """This process's fork server running, and its local clusters forking their workers from
    it until the test ends.

    What stays in this test process afterwards, unused by tests that do not ask for it: the
    server (with this process's environment when the first such test started it; it ends
    with the process), ``multiprocessing``'s temporary folder of the process (an fmionnx
    scratch folder, removed at exit) and Dask's note that its fork server's preload is set."""
    import multiprocessing

    import dask
    import distributed  # noqa: F401 - Dask's distributed settings

    from fmionnx.backends.sweep import workerfork

    if "forkserver" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork server on this platform")
    monkeypatch.setattr(workerfork, "_started", False)  # put back when the test ends
    monkeypatch.delenv(workerfork.SWITCH, raising=False)
    method = dask.config.get(workerfork.METHOD_KEY)
    assert workerfork.start(), "the fork server did not start (see the debug log)"
    yield
    dask.config.set({workerfork.METHOD_KEY: method})


@pytest.fixture
def short_tmpdir() -> Iterator[Path]:
    """An empty temporary folder of a short path, as a user's ``TMPDIR`` is: the command's
    fork server makes its socket in a scratch folder there, and a socket's path has at most
    107 bytes (under a longer one Python's own folder is used, or the workers are spawned)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="fmionnx-test-") as folder:
        yield Path(folder)
