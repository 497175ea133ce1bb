"""A study's cluster is started early and kept warm: a local cluster starts while the system
compiles (not when the study file itself is wrong) and ends while the table and plots are
written; an existing cluster's client, or the caller's, serves many studies of one process."""

from __future__ import annotations

import shutil
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.backends.sweep import engine
from fmionnx.core.errors import DiagnosticError
from fmionnx.pipeline import sweep as pipeline_sweep

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

SYSTEM = """\
fmionnx: 1
name: warm
run: {stop: 0.2, step: 0.01}
components:
  src: {kind: signal, outputs: {y: {sine: {frequency: 1}}}}
  gain: {kind: fmu, path: Gain.fmu, parameters: {v: [0, 0, 0]}}
connections:
  - src.y -> gain.u
"""
STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [0.5, 1, 2]
metrics:
  peak: max(gain.y)
"""


@pytest.fixture
def folder(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    (tmp_path / "study.yaml").write_text(STUDY, encoding="utf-8")
    return tmp_path


@pytest.fixture
def starts(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """What was happening when each local cluster was asked for: the names of the live
    threads (the study's compile runs on the main thread meanwhile)."""
    seen: list[str] = []
    real = engine.open_client

    @contextmanager
    def recording(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
        seen.append(threading.current_thread().name)
        with real(scheduler, workers) as client:
            yield client

    monkeypatch.setattr(engine, "open_client", recording)
    return seen


def test_a_local_cluster_starts_while_the_system_compiles(
    folder: Path, starts: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    compiling: list[bool] = []
    real = pipeline_sweep._StudySource.plan

    def watched(*args: Any) -> Any:
        compiling.append(any(t.name == "fmionnx-cluster-start" for t in threading.enumerate()))
        return real(*args)

    monkeypatch.setattr(pipeline_sweep._StudySource, "plan", watched)
    events = _record_order(monkeypatch)
    table = fmionnx.sweep(folder / "study.yaml", out=folder / "out", workers=1)
    assert list(table["status"]) == ["ok"] * 3
    assert starts == ["fmionnx-cluster-start"]  # started on its own thread ...
    assert compiling == [True]  # ... already running when the system was compiled
    assert events == ["writers", "compile"]  # the results' libraries load from the start
    assert not [t for t in threading.enumerate() if t.name.startswith("fmionnx-cluster")]


def _record_order(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The order in which the study compiled and began loading its table's libraries."""
    events: list[str] = []
    real_compiled = pipeline_sweep._StudySource.plan
    real_writers = pipeline_sweep._ResultsWriters.__init__

    def loading(self: Any) -> None:
        events.append("writers")
        real_writers(self)

    def compiled(*args: Any) -> Any:
        events.append("compile")
        return real_compiled(*args)

    monkeypatch.setattr(pipeline_sweep._StudySource, "plan", compiled)
    monkeypatch.setattr(pipeline_sweep._ResultsWriters, "__init__", loading)
    return events


def test_a_wrong_study_file_starts_no_cluster(folder: Path, starts: list[str]) -> None:
    (folder / "study.yaml").write_text(STUDY.replace("parameters", "parameterz"), encoding="utf-8")
    with pytest.raises(DiagnosticError):
        fmionnx.sweep(folder / "study.yaml", out=folder / "out", workers=1)
    assert starts == []
    assert not (folder / "out").exists()


def test_a_system_with_errors_leaves_no_cluster_running(folder: Path, starts: list[str]) -> None:
    (folder / "system.yaml").write_text(SYSTEM.replace("gain.u", "gain.nope"), encoding="utf-8")
    with pytest.raises(DiagnosticError):
        fmionnx.sweep(folder / "study.yaml", out=folder / "out", workers=1)
    assert len(starts) == 1  # started with the compile, which then failed ...
    assert not [t for t in threading.enumerate() if t.name.startswith("fmionnx-cluster")]
    assert not (folder / "out").exists()  # ... and closed before the error came out


def test_studies_on_an_existing_cluster_share_one_client(
    folder: Path, cluster: str, starts: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    events = _record_order(monkeypatch)
    first = fmionnx.sweep(folder / "study.yaml", out=folder / "one", scheduler=cluster)
    # a cluster that is up: the compile is what the cases wait for, alone
    assert events == ["compile", "writers"]
    client = engine._SHARED[cluster]
    second = fmionnx.sweep(folder / "study.yaml", out=folder / "two", scheduler=cluster)
    assert engine._SHARED[cluster] is client  # the same connection served both
    assert client.status == "running"  # and stays open for the next study
    assert starts == []  # no local cluster
    assert list(first["peak"]) == list(second["peak"])


def test_the_kept_clients_close_on_request(folder: Path, cluster: str) -> None:
    """Before a script ends a cluster it studied on: a kept client left open would try to
    reconnect to it in the background for the rest of the process."""
    fmionnx.sweep(folder / "study.yaml", out=folder / "one", scheduler=cluster)
    client = engine._SHARED[cluster]
    engine.close_shared_clients()
    assert engine._SHARED == {}
    assert client.status == "closed"
    again = fmionnx.sweep(folder / "study.yaml", out=folder / "two", scheduler=cluster)
    assert list(again["status"]) == ["ok"] * 3  # the next study connects anew


def test_a_callers_client_is_used_and_left_open(folder: Path, starts: list[str]) -> None:
    import sys

    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the worker cannot import us
    with engine.open_client(workers=1) as client:
        starts.clear()
        for out in ("a", "b"):
            table = fmionnx.sweep(folder / "study.yaml", out=folder / out, client=client)
            assert list(table["status"]) == ["ok"] * 3
        assert client.status == "running"
        assert starts == []  # the caller's cluster, no other
        # Its worker read the study's system once, for both studies.
        (systems,) = client.run(_systems_read).values()
        assert systems == 1


def _systems_read() -> int:
    """On a worker: the base systems it has read (each once, kept by content hash)."""
    from fmionnx.backends.sweep.case import _SYSTEMS

    return len(_SYSTEMS)


def test_a_client_does_not_combine_with_workers_or_a_scheduler(folder: Path) -> None:
    from fmionnx.pipeline.errors import RequestError

    with pytest.raises(RequestError, match="`client`"):
        fmionnx.sweep(folder / "study.yaml", out=folder / "out", client=object(), workers=2)
