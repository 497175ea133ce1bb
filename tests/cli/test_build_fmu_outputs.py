"""``fmionnx build-fmu`` destroys nothing it did not write: never its own source (a vendor's
FMU rebuilt over itself lost its Windows binary for good), never another file at the output
without --force (a user's notes, a vendor's FMU, a link), while rebuilding over its own
output needs no option; the built FMU keeps other platforms' binaries; `.`, "" and `/` as the
source end in one line, not a traceback."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.core.archive import write_deterministic_zip
from fmionnx.kinds.fmu.build import BUILT_MARK, written_by_build
from tests.conftest import FIXTURES

GAIN = FIXTURES / "fmus" / "Gain"


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["build-fmu", *args])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in result.output
    return result.exit_code, " ".join(result.output.split())


def _vendor_fmu(folder: Path, name: str = "Vendor.fmu") -> Path:
    """Gain's sources with a Windows binary and a stale Linux one, as a vendor ships it."""
    unpacked = folder / "vendor-tree"
    shutil.copytree(GAIN, unpacked)
    (unpacked / "binaries" / "win64").mkdir(parents=True)
    (unpacked / "binaries" / "win64" / "Gain.dll").write_bytes(b"MZ not really a dll")
    (unpacked / "binaries" / "linux64").mkdir()
    (unpacked / "binaries" / "linux64" / "Stale.so").write_bytes(b"old")
    fmu = folder / name
    write_deterministic_zip(unpacked, fmu)
    shutil.rmtree(unpacked)
    return fmu


@pytest.mark.parametrize("force", [[], ["--force"]], ids=["plain", "force"])
def test_the_source_fmu_is_never_the_output(tmp_path: Path, force: list[str]) -> None:
    vendor = _vendor_fmu(tmp_path)
    before = vendor.read_bytes()
    code, output = _invoke(str(vendor), "-o", str(vendor), *force)
    assert code == 2
    assert "is a file this command reads" in output
    assert vendor.read_bytes() == before


def test_a_file_inside_the_source_folder_is_never_the_output(tmp_path: Path) -> None:
    source = tmp_path / "Gain"
    shutil.copytree(GAIN, source)
    description = source / "modelDescription.xml"
    before = description.read_bytes()
    code, output = _invoke(str(source), "-o", str(description), "--force")
    assert code == 2
    assert "lies inside the source folder" in output
    assert description.read_bytes() == before
    # A new file there too (a review): the next build would pack it into the FMU.
    code, output = _invoke(str(source), "-o", str(source / "out.fmu"))
    assert code == 2
    assert "which the build packs whole: choose a name outside it" in output
    assert not (source / "out.fmu").exists()


def test_a_users_file_at_the_output_needs_force(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n", encoding="utf-8")
    code, output = _invoke(str(GAIN), "-o", str(notes))
    assert code == 2
    assert "exists and was not written by `fmionnx build-fmu`" in output
    assert "--force" in output
    assert notes.read_text(encoding="utf-8") == "my notes\n"
    code, output = _invoke(str(GAIN), "-o", str(notes), "--force")
    assert code == 0, output
    assert written_by_build(notes)


def test_a_vendors_fmu_and_a_link_at_the_output_need_force(tmp_path: Path) -> None:
    other = _vendor_fmu(tmp_path, "Other.fmu")
    before = other.read_bytes()
    assert _invoke(str(GAIN), "-o", str(other))[0] == 2
    assert other.read_bytes() == before
    target = tmp_path / "target.txt"
    target.write_text("kept\n", encoding="utf-8")
    link = tmp_path / "link.fmu"
    link.symlink_to(target)
    assert _invoke(str(GAIN), "-o", str(link))[0] == 2
    assert link.is_symlink()
    assert target.read_text(encoding="utf-8") == "kept\n"


def test_rebuilding_over_its_own_output_needs_no_option(tmp_path: Path) -> None:
    out = tmp_path / "Gain.fmu"
    assert _invoke(str(GAIN), "-o", str(out))[0] == 0
    with zipfile.ZipFile(out) as archive:
        assert archive.comment == BUILT_MARK
    first = out.read_bytes()
    code, output = _invoke(str(GAIN), "-o", str(out))
    assert code == 0, output
    assert out.read_bytes() == first  # deterministic, comment included


def test_other_platforms_binaries_are_kept_and_this_platforms_replaced(tmp_path: Path) -> None:
    vendor = _vendor_fmu(tmp_path)
    code, output = _invoke(str(vendor))
    assert code == 0, output
    with zipfile.ZipFile(tmp_path / "Vendor.built.fmu") as archive:
        names = archive.namelist()
        assert archive.read("binaries/win64/Gain.dll") == b"MZ not really a dll"
    assert "binaries/linux64/Gain.so" in names
    assert "binaries/linux64/Stale.so" not in names
    assert "sources/model.c" in names


@pytest.mark.parametrize("name", [".", ""])
def test_the_current_folder_as_source_writes_the_fmu_beside_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    shutil.copytree(GAIN, tmp_path / "Gain")
    monkeypatch.chdir(tmp_path / "Gain")
    code, output = _invoke(name)
    assert code == 0, output
    assert written_by_build(tmp_path / "Gain.fmu")


def test_the_root_folder_as_source_asks_for_an_output(tmp_path: Path) -> None:
    code, output = _invoke("/")
    assert code == 2
    assert "`/` has no name to derive the output's from: name it with --output" in output
    code, output = _invoke("/", "-o", str(tmp_path / "x.fmu"))  # nothing is outside `/`
    assert code == 2
    assert "lies inside the source folder `/`" in output
    assert not (tmp_path / "x.fmu").exists()


def test_a_folder_without_a_model_description_is_not_copied(tmp_path: Path) -> None:
    (tmp_path / "src").mkdir()
    code, output = _invoke(str(tmp_path / "src"), "-o", str(tmp_path / "x.fmu"))
    assert code == 1
    assert "has no modelDescription.xml" in output
    assert not (tmp_path / "x.fmu").exists()
