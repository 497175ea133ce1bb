"""A script that calls ``fmionnx.sweep`` at its top level, without the ``__main__`` guard.

The local cluster's workers are spawned: each runs the calling script again before it becomes
a worker, so the call repeats inside every starting worker -- where it would prepare, or with
``force`` wipe, the very results folder the real study is writing. It is refused there before
anything is touched, and the script itself gets a clear error saying how to write it; the
guarded script runs. Real processes: the scripts run in a fresh interpreter each.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.sweep.conftest import WriteStudy

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 2]
metrics:
  y_end: final(gain.y)
"""

CALL = 'table = fmionnx.sweep("study.yaml", out="results", workers=1, force=True)\n'
GUARD = 'if __name__ == "__main__":\n    '


def _run_script(folder: Path, body: str) -> subprocess.CompletedProcess[str]:
    script = folder / "run_study.py"
    script.write_text(f"import fmionnx\n\n{body}print(len(table))\n", encoding="utf-8")
    return subprocess.run(
        [sys.executable, script.name], cwd=folder, capture_output=True, text=True, timeout=300,
        check=False,
    )  # fmt: skip


def test_a_script_without_the_main_guard_gets_a_clear_error(write_study: WriteStudy) -> None:
    folder = write_study(STUDY).parent
    done = _run_script(folder, CALL)

    assert done.returncode != 0
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("fmionnx.backends.sweep.engine.ClusterStartError: ")
    assert "the local Dask cluster could not start its workers" in last
    assert 'under `if __name__ == "__main__":`' in last
    # The worker's own call was refused before it touched anything.
    assert "fmionnx.sweep was called while a worker process was starting" in done.stderr


def test_the_same_script_with_the_guard_runs(write_study: WriteStudy) -> None:
    folder = write_study(STUDY).parent
    done = _run_script(folder, GUARD + CALL + "    ")

    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "2"
    assert (folder / "results" / "cases.csv").is_file()


def _nanny_fails(workers: int, scratch: Path) -> object:
    """Dask's local cluster failing to start its workers (the part that fails is Dask's)."""
    raise RuntimeError("Nanny failed to start.")


@pytest.fixture
def finished(write_study: WriteStudy, tmp_path: Path) -> tuple[Path, Path]:
    """A study and the results folder of a finished run of it."""
    import fmionnx

    study = write_study(STUDY)
    out = tmp_path / "out"
    fmionnx.sweep(study, out=out, workers=1)
    return study, out


def test_the_command_reports_a_local_cluster_that_cannot_start(
    write_study: WriteStudy, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from typer.testing import CliRunner

    from fmionnx.backends.sweep import engine
    from fmionnx.cli import app

    monkeypatch.setattr(engine, "_local_cluster", _nanny_fails)
    result = CliRunner().invoke(
        app,
        ["sweep", str(write_study(STUDY)), "--out", str(tmp_path / "out")],
        env={"COLUMNS": "200", "NO_COLOR": "1"},
    )
    assert result.exit_code == 1, result.output
    assert "the local Dask cluster could not start its workers (Nanny failed to start.)" in (
        " ".join(result.output.split())
    )
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()  # the workers are started before the folder is made


def test_force_removes_nothing_when_the_local_cluster_cannot_start(
    finished: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    import fmionnx
    from fmionnx.backends.sweep import engine

    study, out = finished
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    monkeypatch.setattr(engine, "_local_cluster", _nanny_fails)
    with pytest.raises(engine.ClusterStartError):
        fmionnx.sweep(study, out=out, workers=1, force=True)
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before


def test_a_folder_that_cannot_take_the_study_is_said_before_any_cluster_starts(
    finished: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    import fmionnx
    from fmionnx.backends.sweep import engine
    from fmionnx.results.study import StudyFolderError

    study, out = finished

    def no_cluster_expected(workers: int, scratch: Path) -> object:
        raise AssertionError("a cluster was started before the folder was checked")

    monkeypatch.setattr(engine, "_local_cluster", no_cluster_expected)
    with pytest.raises(StudyFolderError, match="already holds a study's results"):
        fmionnx.sweep(study, out=out, workers=1)
