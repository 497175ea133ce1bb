"""``fmionnx build-fmu`` of a source folder holding symbolic links: a link to a file of the
folder is packed as that file; a broken link, a link out of the folder (a user's private file
would ship in the FMU), a link to a folder and a special file are refused in one error line
naming the entry, exit 1, nothing written."""

from __future__ import annotations

import os
import shutil
import zipfile
from pathlib import Path

from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.kinds.fmu.buildcheck import SHARED_SOURCES_MARK
from tests.conftest import FIXTURES

GAIN = FIXTURES / "fmus" / "Gain"


def _gain(tmp_path: Path) -> Path:
    """A complete copy of the Gain source folder (its glue links copied as files)."""
    folder = tmp_path / "Gain"
    shutil.copytree(GAIN, folder)
    return folder


def _build(source: Path, output: Path) -> tuple[int, str]:
    result = CliRunner().invoke(
        app, ["build-fmu", str(source), "-o", str(output)], catch_exceptions=False
    )
    return result.exit_code, " ".join(result.output.split())


def test_a_link_out_of_the_source_folder_is_refused_and_nothing_ships(tmp_path: Path) -> None:
    secret = tmp_path / "private.txt"
    secret.write_text("the user's private key\n")
    folder = _gain(tmp_path)
    (folder / "sources" / "notes.txt").symlink_to(Path("..", "..", "private.txt"))
    out = tmp_path / "Gain.fmu"
    code, output = _build(folder, out)
    assert code == 1, output
    assert "error[E017]" in output
    assert "`sources/notes.txt` is a link to `../../private.txt`, outside the source folder" in (
        output
    )
    assert SHARED_SOURCES_MARK in output  # the hint says how to share files on purpose
    assert "Traceback" not in output
    assert not out.exists()


def test_an_absolute_link_to_a_folder_outside_is_refused(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / SHARED_SOURCES_MARK).write_text("")  # the mark shares files, not folders
    folder = _gain(tmp_path)
    (folder / "documentation").symlink_to(elsewhere)
    code, output = _build(folder, tmp_path / "Gain.fmu")
    assert code == 1, output
    assert f"`documentation` is a link to `{elsewhere}`, outside the source folder" in output


def test_a_broken_link_is_named_with_its_target(tmp_path: Path) -> None:
    folder = _gain(tmp_path)
    (folder / "sources" / "old.h").symlink_to("gone.h")
    out = tmp_path / "Gain.fmu"
    code, output = _build(folder, out)
    assert code == 1, output
    assert "error[E010]" in output
    assert "`sources/old.h` is a link to `gone.h`, which does not exist" in output
    assert "Errno" not in output  # not shutil's list of (source, destination, error)
    assert not out.exists()


def test_a_loop_of_links_is_a_broken_link(tmp_path: Path) -> None:
    folder = _gain(tmp_path)
    (folder / "a").symlink_to("b")
    (folder / "b").symlink_to("a")
    code, output = _build(folder, tmp_path / "Gain.fmu")
    assert code == 1, output
    assert "`a` is a link to `b`, which does not exist" in output


def test_a_link_to_a_folder_inside_is_refused_not_followed(tmp_path: Path) -> None:
    folder = _gain(tmp_path)
    (folder / "sources" / "again").symlink_to("..")  # copied whole, it would never end
    code, output = _build(folder, tmp_path / "Gain.fmu")
    assert code == 1, output
    assert "error[E011]" in output
    assert "`sources/again` is a link to `..`, a folder" in output


def test_a_fifo_in_the_source_folder_is_refused(tmp_path: Path) -> None:
    folder = _gain(tmp_path)
    os.mkfifo(folder / "documentation.pipe")
    code, output = _build(folder, tmp_path / "Gain.fmu")
    assert code == 1, output
    assert "error[E011]" in output
    assert "`documentation.pipe` in the source folder is a special file" in output


def test_links_inside_and_to_a_shared_folder_are_packed_as_files(tmp_path: Path) -> None:
    shared = tmp_path / "common"
    shared.mkdir()
    (shared / SHARED_SOURCES_MARK).write_text("shared glue\n")
    (shared / "extra.h").write_text("/* shared */\n")
    folder = _gain(tmp_path)
    (folder / "sources" / "extra.h").symlink_to(Path("..", "..", "common", "extra.h"))
    (folder / "documentation").mkdir()
    (folder / "documentation" / "model.h").symlink_to(Path("..", "sources", "model.h"))
    out = tmp_path / "Gain.fmu"
    code, output = _build(folder, out)
    assert code == 0, output
    with zipfile.ZipFile(out) as archive:
        assert archive.read("sources/extra.h") == b"/* shared */\n"
        assert archive.read("documentation/model.h") == (GAIN / "sources" / "model.h").read_bytes()
        assert not any(SHARED_SOURCES_MARK in name for name in archive.namelist())
