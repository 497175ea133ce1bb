"""``fmionnx run`` without ``--out`` writes to ``out/<system name>/`` and says so (issue #16).

The default folder follows the ``--out`` rules of ``fmionnx.results.outdir``: a second run
replaces the first one's files (and removes those it does not write again), a user's file in
it is kept, and a folder of foreign files is refused before the run.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.results.outdir import default_folder

SYSTEM = """\
fmionnx: 1
name: chain
run: {{stop: 0.05, step: 0.01}}
components:
  a: {{kind: fmu, path: Gain.fmu, parameters: {{u: 1.0}}}}
  b: {{kind: fmu, path: Gain.fmu}}
connections:
  - a.y -> b.u
{plots}"""

PLOT = "plots:\n  - {y: [b.y], file: gain}\n"


def run(*args: str) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of ``fmionnx run ARGS``."""
    result = CliRunner().invoke(app, ["run", *args], env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def project(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> Path:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM.format(plots=PLOT), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_a_run_without_out_writes_to_out_system_name_and_names_it_last(project: Path) -> None:
    code, stdout, _ = run("system.yaml")
    assert code == 0
    assert stdout.splitlines()[-1] == "Results: out/chain"
    folder = project / "out" / "chain"
    assert sorted(p.name for p in folder.iterdir()) == [
        ".fmionnx-owned",  # the ownership record: what fmionnx may delete there
        "gain.png",
        "results.csv",
        "run.json",
    ]


def test_quiet_still_names_the_folder(project: Path) -> None:
    code, stdout, stderr = run("system.yaml", "-q")
    assert code == 0
    assert stdout == "Results: out/chain\n"
    assert stderr == ""


def test_a_second_run_replaces_the_first_runs_files_and_keeps_a_users_file(
    project: Path,
) -> None:
    assert run("system.yaml", "-q")[0] == 0
    folder = project / "out" / "chain"
    (folder / "notes.txt").write_text("mine\n", encoding="utf-8")
    (project / "system.yaml").write_text(SYSTEM.format(plots=""), encoding="utf-8")
    assert run("system.yaml", "-q", "--stop-time", "0.03")[0] == 0
    assert sorted(p.name for p in folder.iterdir()) == [
        ".fmionnx-owned",
        "notes.txt",
        "results.csv",
        "run.json",
    ]
    assert (folder / "notes.txt").read_text(encoding="utf-8") == "mine\n"
    second = json.loads((folder / "run.json").read_text(encoding="utf-8"))
    assert second["files"] == ["results.csv", "run.json"]
    assert len((folder / "results.csv").read_text(encoding="utf-8").splitlines()) == 1 + 4


def test_a_default_folder_of_foreign_files_is_refused_and_left_alone(project: Path) -> None:
    folder = project / "out" / "chain"
    folder.mkdir(parents=True)
    (folder / "results.csv").write_text("my own table\n", encoding="utf-8")
    code, stdout, stderr = run("system.yaml", "-q")
    assert code == 2
    assert stdout == ""
    assert " ".join(stderr.split()) == (
        "error: the default results folder `out/chain` holds files that are not the output "
        "of an earlier fmionnx run; choose a folder with --out, or use --force to write into it"
    )
    assert [p.name for p in folder.iterdir()] == ["results.csv"]
    assert (folder / "results.csv").read_text(encoding="utf-8") == "my own table\n"
    assert run("system.yaml", "-q", "--force")[0] == 0
    assert (folder / "run.json").is_file()


def test_no_out_writes_nothing_and_names_no_folder(project: Path) -> None:
    code, stdout, _ = run("system.yaml", "--no-out", "-q")
    assert code == 0
    assert stdout == ""
    assert not (project / "out").exists()


def test_out_and_no_out_together_are_a_usage_error(project: Path) -> None:
    code, _, stderr = run("system.yaml", "--no-out", "--out", "elsewhere")
    assert code == 2
    assert "--out and --no-out exclude each other" in stderr
    assert not (project / "elsewhere").exists()


def test_a_single_fmu_runs_into_a_folder_named_after_it(
    project: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    code, stdout, _ = run("Gain.fmu", "-q", "--stop-time", "0.02")
    assert code == 0
    assert stdout.splitlines()[-1] == "Results: out/Gain"
    assert (project / "out" / "Gain" / "results.csv").is_file()


@pytest.mark.parametrize(
    ("name", "folder"),
    [
        ("sign_follower", "sign_follower"),
        ("a/../b", "a_.._b"),
        ("..", "system"),
        (".hidden", "hidden"),
        ("with space", "with_space"),
    ],
)
def test_the_default_folder_is_one_plain_visible_name(name: str, folder: str) -> None:
    assert default_folder(name) == Path("out") / folder
