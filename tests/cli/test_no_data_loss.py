"""No command destroys user data: convert, export, lock, run (issue #17, "runs you can trust").

Each test plants something of the user's where fmionnx writes (a folder, a file, a symbolic
link pointing outside) and checks it is untouched afterwards; and that re-running a command
over its own earlier output still works without ``--force``.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app

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


def cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), catch_exceptions=False)
    return result.exit_code, " ".join(result.output.split())


@pytest.fixture
def project(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> Path:
    """``system.yaml`` of two gains in the working directory; ``outside/`` holds a secret."""
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM.format(plots=""), encoding="utf-8")
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "secret.txt").write_text("keep me\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


SECRET = Path("outside") / "secret.txt"


def plant_link(at: Path) -> None:
    """A symbolic link at ``at`` pointing to the secret outside the folder."""
    at.parent.mkdir(parents=True, exist_ok=True)
    at.symlink_to(SECRET.resolve())


def secret_intact() -> bool:
    return SECRET.read_text(encoding="utf-8") == "keep me\n"


# -- convert -----------------------------------------------------------------------------


@pytest.fixture
def archive(project: Path) -> Path:
    assert cli("export", "system.yaml", "-o", "system.ssp")[0] == 0
    return project / "system.ssp"


def test_convert_refuses_a_users_files_folder_and_leaves_it_intact(archive: Path) -> None:
    (archive.parent / "important_files").mkdir()
    (archive.parent / "important_files" / "thesis.tex").write_text("years of work\n")
    code, output = cli("convert", "system.ssp", "-o", "important.yaml")
    assert code == 2
    assert output == (
        "error: `important_files` exists and was not extracted by `fmionnx convert`; "
        "not replacing it (use --force to replace it)"
    )
    assert (archive.parent / "important_files" / "thesis.tex").read_text() == "years of work\n"
    assert not (archive.parent / "important.yaml").exists()


def test_convert_refuses_a_users_yaml_file(archive: Path) -> None:
    (archive.parent / "mine.yaml").write_text("hand written\n")
    code, output = cli("convert", "system.ssp", "-o", "mine.yaml")
    assert code == 2
    assert "`mine.yaml` exists and was not written by `fmionnx convert`" in output
    assert (archive.parent / "mine.yaml").read_text() == "hand written\n"
    assert not (archive.parent / "mine_files").exists()


def test_convert_twice_over_its_own_output_needs_no_force(archive: Path) -> None:
    assert cli("convert", "system.ssp", "-o", "back.yaml")[0] == 0
    files = archive.parent / "back_files"
    assert (files / ".fmionnx-convert").is_file()
    (files / "stale.txt").write_text("from the first convert\n")
    code, output = cli("convert", "system.ssp", "-o", "back.yaml")
    assert (code, output) == (0, "wrote back.yaml")
    assert not (files / "stale.txt").exists()  # the folder is ours: replaced wholesale
    assert cli("validate", "back.yaml")[0] == 0


def test_convert_with_force_replaces_the_folder(archive: Path) -> None:
    (archive.parent / "important_files").mkdir()
    code, _ = cli("convert", "system.ssp", "-o", "important.yaml", "--force")
    assert code == 0
    assert (archive.parent / "important_files" / ".fmionnx-convert").is_file()


def test_convert_over_a_link_replaces_the_link_not_its_target(archive: Path) -> None:
    plant_link(archive.parent / "linked.yaml")
    assert cli("convert", "system.ssp", "-o", "linked.yaml")[0] == 2
    assert cli("convert", "system.ssp", "-o", "linked.yaml", "--force")[0] == 0
    assert not (archive.parent / "linked.yaml").is_symlink()
    assert secret_intact()


# -- export ------------------------------------------------------------------------------


def test_export_refuses_an_archive_it_did_not_write(project: Path) -> None:
    (project / "vendor.ssp").write_bytes(b"the vendor's archive")
    code, output = cli("export", "system.yaml", "-o", "vendor.ssp")
    assert code == 2
    assert output == (
        "error: `vendor.ssp` exists and was not written by `fmionnx export`; "
        "not replacing it (use --force to replace it)"
    )
    assert (project / "vendor.ssp").read_bytes() == b"the vendor's archive"
    assert cli("export", "system.yaml", "-o", "vendor.ssp", "--force")[0] == 0


def test_export_twice_over_its_own_archive_needs_no_force(project: Path) -> None:
    assert cli("export", "system.yaml", "-o", "system.ssp")[0] == 0
    first = (project / "system.ssp").read_bytes()
    assert cli("export", "system.yaml", "-o", "system.ssp") == (0, "wrote system.ssp")
    assert (project / "system.ssp").read_bytes() == first


def test_export_with_force_over_a_link_leaves_the_target_alone(project: Path) -> None:
    plant_link(project / "linked.ssp")
    assert cli("export", "system.yaml", "-o", "linked.ssp")[0] == 2
    assert cli("export", "system.yaml", "-o", "linked.ssp", "--force")[0] == 0
    assert not (project / "linked.ssp").is_symlink()
    assert secret_intact()


# -- lock --------------------------------------------------------------------------------


def test_lock_refuses_a_hand_written_file_at_the_lock_name(project: Path) -> None:
    (project / "system.fmionnx.lock").write_text("my notes\n")
    code, output = cli("lock", "system.yaml")
    assert code == 2
    assert output == (
        "error: `system.fmionnx.lock` exists and was not written by `fmionnx lock`; "
        "not replacing it (use --force to replace it)"
    )
    assert (project / "system.fmionnx.lock").read_text() == "my notes\n"
    assert cli("lock", "system.yaml", "--force")[0] == 0
    assert (project / "system.fmionnx.lock").read_text().startswith("# Interface lock of")


def test_lock_twice_needs_no_force_and_keeps_an_unchanged_file(project: Path) -> None:
    assert cli("lock", "system.yaml") == (0, "wrote system.fmionnx.lock")
    lock = project / "system.fmionnx.lock"
    stamp = lock.stat().st_mtime_ns
    assert cli("lock", "system.yaml") == (0, "up to date: system.fmionnx.lock")
    assert lock.stat().st_mtime_ns == stamp


def test_lock_never_writes_through_a_planted_link(project: Path) -> None:
    plant_link(project / "system.fmionnx.lock")
    assert cli("lock", "system.yaml")[0] == 2
    assert cli("lock", "system.yaml", "--force")[0] == 0
    assert not (project / "system.fmionnx.lock").is_symlink()
    assert secret_intact()


# -- run --out ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["results.csv", "run.json", "gain.png"])
def test_run_never_writes_through_a_link_planted_in_out(project: Path, name: str) -> None:
    (project / "system.yaml").write_text(SYSTEM.format(plots=PLOT), encoding="utf-8")
    assert cli("run", "system.yaml", "--out", "out", "-q")[0] == 0  # an earlier run
    (project / "out" / name).unlink()
    plant_link(project / "out" / name)
    code, _ = cli("run", "system.yaml", "--out", "out", "-q", "--force")
    assert code == 0
    assert not (project / "out" / name).is_symlink()
    assert (project / "out" / name).stat().st_size > 0
    assert secret_intact()


def test_run_refuses_an_out_folder_of_foreign_files(project: Path) -> None:
    (project / "photos").mkdir()
    (project / "photos" / "results.csv").write_text("my own table\n")
    code, output = cli("run", "system.yaml", "--out", "photos", "-q")
    assert code == 2
    assert output == (
        "error: --out `photos` holds files that are not the output of an earlier fmionnx run; "
        "choose an empty folder or use --force to write into it"
    )
    assert sorted(p.name for p in (project / "photos").iterdir()) == ["results.csv"]
    assert (project / "photos" / "results.csv").read_text() == "my own table\n"


@pytest.mark.parametrize("force", [False, True])
def test_run_refuses_a_studys_folder_and_leaves_the_study_intact(
    project: Path, force: bool
) -> None:
    (project / "study.yaml").write_text(
        "fmionnx: 1\nsystem: system.yaml\nparameters:\n  b.k: [1, 2]\n"
        "metrics:\n  y_end: final(b.y)\n",
        encoding="utf-8",
    )
    code, output = cli("sweep", "study.yaml", "--out", "study", "--workers", "1", "-q")
    assert code == 0, output
    before = sorted(p.relative_to(project).as_posix() for p in (project / "study").rglob("*"))
    assert "study/study.json" in before
    code, output = cli("run", "system.yaml", "--out", "study", "-q", *(["--force"] * force))
    assert code == 2
    assert output == (
        "error: --out `study` holds a study's results (study.json, records/): a run writes "
        "into a folder of its own, even with --force; choose another folder"
    )
    after = sorted(p.relative_to(project).as_posix() for p in (project / "study").rglob("*"))
    assert after == before


def test_a_folder_that_merely_has_a_records_folder_is_the_users(project: Path) -> None:
    (project / "data" / "records").mkdir(parents=True)
    (project / "data" / "records" / "log.txt").write_text("mine\n")
    (project / "data" / "study.json").write_text("{}\n")  # not one fmionnx can prove
    code, output = cli("run", "system.yaml", "--out", "data", "-q")
    assert code == 2
    assert "holds files that are not the output of an earlier fmionnx run" in output
    code, output = cli("run", "system.yaml", "--out", "data", "-q", "--force")
    assert code == 0, output
    assert (project / "data" / "records" / "log.txt").read_text() == "mine\n"
    assert (project / "data" / "study.json").read_text() == "{}\n"


def test_the_study_marks_a_run_refuses_are_what_a_study_writes() -> None:
    from fmionnx.results import outdir, study

    assert outdir.STUDY_MARKS == (study.DESCRIPTION, study.RECORDS)


def test_a_rerun_removes_its_stale_plot_and_keeps_the_users_file(project: Path) -> None:
    (project / "system.yaml").write_text(SYSTEM.format(plots=PLOT), encoding="utf-8")
    out = project / "out"
    assert cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    assert json.loads((out / "run.json").read_text())["files"] == [
        "gain.png",
        "results.csv",
        "run.json",
    ]
    (out / "notes.txt").write_text("mine\n")
    (project / "system.yaml").write_text(SYSTEM.format(plots=""), encoding="utf-8")
    assert cli("run", "system.yaml", "--out", "out", "-q")[0] == 0  # no --force needed
    assert sorted(p.name for p in out.iterdir()) == [
        ".fmionnx-owned",
        "notes.txt",
        "results.csv",
        "run.json",
    ]
    assert (out / "notes.txt").read_text() == "mine\n"


def test_a_stale_entry_naming_a_path_outside_out_is_ignored(project: Path) -> None:
    out = project / "out"
    assert cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    info = json.loads((out / "run.json").read_text())
    info["files"] += ["../outside/secret.txt", str(SECRET.resolve())]
    (out / "run.json").write_text(json.dumps(info))
    assert cli("run", "system.yaml", "--out", "out", "-q")[0] == 0
    assert secret_intact()


def test_record_into_out_is_listed_and_not_written_through_a_link(project: Path) -> None:
    plant_link(project / "out" / "run.mcap")
    (project / "out" / "run.json").unlink(missing_ok=True)
    code, _ = cli("run", "system.yaml", "--out", "out", "-q", "--force", "--record", "out/run.mcap")
    assert code == 0
    assert not (project / "out" / "run.mcap").is_symlink()
    assert "run.mcap" in json.loads((project / "out" / "run.json").read_text())["files"]
    assert secret_intact()


@pytest.mark.parametrize(
    "command",
    [
        ("graph", "system.yaml", "-o", "{name}"),
        ("schema", "-o", "{name}"),
        ("ros2", "launch-file", "system.yaml", "-o", "{name}"),
    ],
    ids=["graph", "schema", "launch-file"],
)
def test_derived_files_are_never_written_through_a_link(
    project: Path, command: tuple[str, ...]
) -> None:
    name = {"graph": "g.dot", "schema": "s.json", "ros2": "r.launch.py"}[command[0]]
    plant_link(project / name)
    code, output = cli(*(part.format(name=name) for part in command))
    assert code == 0, output
    assert not (project / name).is_symlink()
    assert (project / name).stat().st_size > 0
    assert secret_intact()


@pytest.mark.parametrize(
    "command",
    [
        ("graph", "system.yaml", "-f", "dot", "-o", "{target}"),
        ("ros2", "launch-file", "system.yaml", "-o", "{target}"),
    ],
    ids=["graph", "launch-file"],
)
@pytest.mark.parametrize("target", ["system.yaml", "Gain.fmu"])
def test_a_derived_file_is_never_written_over_what_the_command_reads(
    project: Path, command: tuple[str, ...], target: str
) -> None:
    before = (project / target).read_bytes()
    code, output = cli(*(part.format(target=target) for part in command))
    assert code == 2
    assert output == (
        f"error: --output `{target}` is a file this command reads: choose another name"
    )
    assert (project / target).read_bytes() == before


@pytest.mark.parametrize(("option", "name"), [("--record", "run.mcap"), ("--rrd", "run.rrd")])
def test_a_recording_never_replaces_a_users_file_without_force(
    project: Path, option: str, name: str
) -> None:
    (project / name).write_text("my notes\n")
    code, output = cli("run", "system.yaml", "--out", "out", "-q", option, name)
    kind = "an MCAP recording fmionnx wrote" if option == "--record" else "a Rerun recording"
    assert code == 2
    assert output == (
        f"error: {option} `{name}` exists and is not {kind}; not replacing it (choose another "
        "name, or use --force to replace it)"
    )
    assert (project / name).read_text() == "my notes\n"
    assert not (project / "out").exists()
    code, output = cli("run", "system.yaml", "--out", "out", "-q", option, name, "--force")
    assert code == 0, output
    assert (project / name).read_bytes()[:3] in (b"\x89MC", b"RRF")


@pytest.mark.parametrize("option", ["--record", "--rrd"])
def test_a_recording_never_replaces_the_system_file_even_with_force(
    project: Path, option: str
) -> None:
    before = (project / "system.yaml").read_bytes()
    code, output = cli("run", "system.yaml", "--out", "out", "-q", "--force", option, "system.yaml")
    assert code == 2
    assert (
        output == f"error: {option} `system.yaml` is the file this run reads: choose another name"
    )
    assert (project / "system.yaml").read_bytes() == before


@pytest.mark.parametrize(
    "content",
    [b"\x89MCAP0\r\n", b"\x89MCAP0\r\n\x01", b"\x89MCAP0\r\n\x01" + bytes(8) + b"\xff\xff\xff\xff"],
    ids=["magic-only", "opcode-only", "a-string-longer-than-the-file"],
)
def test_a_cut_short_mcap_file_is_refused_in_one_line(project: Path, content: bytes) -> None:
    (project / "run.mcap").write_bytes(content)
    code, output = cli("run", "system.yaml", "--out", "out", "-q", "--record", "run.mcap")
    assert code == 2
    assert "exists and is not an MCAP recording fmionnx wrote" in output
    assert (project / "run.mcap").read_bytes() == content


def test_a_recording_replaces_its_own_earlier_recording(project: Path) -> None:
    assert cli("run", "system.yaml", "--out", "out", "-q", "--record", "run.mcap")[0] == 0
    first = (project / "run.mcap").stat().st_mtime_ns
    code, output = cli("run", "system.yaml", "--out", "out", "-q", "--record", "run.mcap")
    assert code == 0, output
    assert (project / "run.mcap").stat().st_mtime_ns != first
