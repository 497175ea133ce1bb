"""Output paths are checked before any work: a clear usage error, never a traceback or a run
that computes and then cannot write. The last net, in ``main``, turns a file-system refusal
into one line."""

from __future__ import annotations

import errno
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app, main
from tests.conftest import REPO

SYSTEM = str(REPO / "systems" / "sign_follower.yaml")
GAIN = str(REPO / "tests" / "fixtures" / "fmus" / "Gain")


@pytest.fixture
def a_file(tmp_path: Path) -> Path:
    path = tmp_path / "plain.txt"
    path.write_text("not a folder\n", encoding="utf-8")
    return path


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, " ".join(result.output.split())


@pytest.mark.parametrize(
    "command",
    [
        ["graph", SYSTEM, "-o"],
        ["schema", "-o"],
        ["build-fmu", GAIN, "-o"],
        ["export", SYSTEM, "-o"],
        ["run", SYSTEM, "--record"],
    ],
)
def test_an_output_file_under_a_plain_file_is_a_usage_error(
    command: list[str], a_file: Path
) -> None:
    suffix = {"export": ".ssp", "graph": ".dot"}.get(command[0], ".x")  # a format they write
    target = a_file / f"out{suffix}"
    code, output = _invoke(*command, str(target))
    assert code == 2
    assert f"`{target}`: the folder `{a_file}` exists and is not a folder" in output


@pytest.mark.parametrize(
    ("command", "option"),
    [(["graph", SYSTEM, "-f", "dot", "-o"], "--output"), (["run", SYSTEM, "--record"], "--record")],
)
def test_an_output_file_that_is_a_folder_is_a_usage_error(
    command: list[str], option: str, tmp_path: Path
) -> None:
    code, output = _invoke(*command, str(tmp_path))
    assert code == 2
    assert f"{option} `{tmp_path}` is a folder; expected a file name" in output


@pytest.mark.parametrize("option", ["--rrd", "--record"])
def test_an_output_file_in_a_folder_that_takes_no_file_is_a_usage_error_naming_it(
    option: str, tmp_path: Path
) -> None:
    """``/proc`` passes the folder checks (it exists; root may write there) but takes no new
    file: the run failed at its start naming the writer's temporary ``.part`` file, exit 1."""
    target = "/proc/fmionnx-x.out"
    code, output = _invoke("run", SYSTEM, option, target, "--out", str(tmp_path / "out"))
    assert code == 2
    assert f"{option} `{target}`: no file can be made in `/proc`" in output
    assert ".part" not in output
    assert not (tmp_path / "out").exists()


def test_run_out_naming_a_file_fails_before_the_run(a_file: Path) -> None:
    code, output = _invoke("run", SYSTEM, "--out", str(a_file))
    assert code == 2
    assert f"--out `{a_file}` exists and is not a folder" in output
    assert "running" not in output
    assert a_file.read_text(encoding="utf-8") == "not a folder\n"


def test_main_turns_a_file_system_refusal_into_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    def full_disk(self: Path, *args: object, **kwargs: object) -> int:
        raise OSError(errno.ENOSPC, "No space left on device", str(self))

    monkeypatch.setattr(Path, "replace", full_disk)  # the disk is the peer here
    monkeypatch.setattr(sys, "argv", ["fmionnx", "schema", "-o", str(tmp_path / "s.json")])
    with pytest.raises(SystemExit) as ended:
        main()
    assert ended.value.code == 1
    err = capsys.readouterr().err
    assert err == (
        f"error: --output `{tmp_path / 's.json'}`: cannot write it (No space left on device)\n"
    )
    assert list(tmp_path.iterdir()) == []  # nothing half-written: the temporary file removed


@pytest.mark.parametrize("leads", ["nowhere", "loop"])
def test_an_out_link_that_leads_nowhere_is_said_so(tmp_path: Path, leads: str) -> None:
    link = tmp_path / "results"
    link.symlink_to(tmp_path / "missing" if leads == "nowhere" else link)
    code, output = _invoke("run", SYSTEM, "--out", str(link))
    assert code == 2
    assert f"--out `{link}` is a symbolic link that leads nowhere" in output
    assert link.is_symlink()
    assert not (tmp_path / "missing").exists()


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        (
            ["--out", "{out}", "--rrd", "{out}/run.json"],
            "--rrd `{out}/run.json` is a file the run writes into its results folder `{out}`",
        ),
        (
            ["--out", "{out}", "--record", "{out}/results.csv"],
            "--record `{out}/results.csv` is a file the run writes into its results folder",
        ),
        (
            ["--out", "{out}", "--record", "{out}/trajectory.png"],
            "--record `{out}/trajectory.png` is a file the run writes into its results folder",
        ),
        (
            ["--no-out", "--record", "{tmp}/both.mcap", "--rrd", "{tmp}/both.mcap"],
            "--record and --rrd name the same file `{tmp}/both.mcap`: choose two names",
        ),
    ],
)
def test_recordings_never_share_a_path_with_each_other_or_the_results(
    tmp_path: Path, options: list[str], expected: str
) -> None:
    """A bug hunt: `--rrd out/run.json` exited 0 with run.json a Rerun recording (the run's
    metadata lost) and `wrote out/run.json` said twice; `--record x --rrd x` kept one."""
    out = tmp_path / "out"
    filled = [o.format(out=out, tmp=tmp_path) for o in options]
    code, output = _invoke("run", GAIN, "--stop-time", "0.1", *filled)
    assert code == 2, output
    assert expected.format(out=out, tmp=tmp_path) in output
    assert not out.exists()  # refused before the results folder was made
    assert list(tmp_path.iterdir()) == []


def test_a_run_whose_system_fails_to_load_leaves_no_folder_it_made(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text("components: {g: {fmu: missing.fmu}}\n", encoding="utf-8")
    out = tmp_path / "new" / "deeper" / "results"
    record = tmp_path / "rec" / "run.mcap"
    code, _ = _invoke("run", str(broken), "--out", str(out), "--record", str(record))
    assert code == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.yaml"]


def test_a_failed_start_keeps_folders_that_existed_or_hold_anything(tmp_path: Path) -> None:
    from fmionnx.pipeline.outputs import check_output_folder, undone_on_failure

    (tmp_path / "kept").mkdir()
    made_then_filled = tmp_path / "filled" / "out"

    def fail_after_making() -> None:
        with undone_on_failure():
            check_output_folder(tmp_path / "kept", "--out")
            check_output_folder(tmp_path / "kept" / "empty", "--out")
            check_output_folder(made_then_filled, "--out")
            (made_then_filled / "note.txt").write_text("mine\n", encoding="utf-8")
            raise RuntimeError

    with pytest.raises(RuntimeError):
        fail_after_making()
    assert (tmp_path / "kept").is_dir()
    assert not (tmp_path / "kept" / "empty").exists()
    assert (made_then_filled / "note.txt").is_file()
    with undone_on_failure():  # no failure: what was made stays
        check_output_folder(tmp_path / "kept" / "stays", "--out")
    assert (tmp_path / "kept" / "stays").is_dir()


def test_a_path_through_a_new_folder_removes_what_it_made_not_what_was_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`--out new/../out2` with `out2` there before: the folder made was `new`, not `out2`
    (a review: the user's empty `out2` was removed and `new` was left)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out2").mkdir()
    (tmp_path / "broken.yaml").write_text("components: {g: {fmu: missing.fmu}}\n")
    code, _ = _invoke("run", "broken.yaml", "--out", "new/../out2")
    assert code == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.yaml", "out2"]
