"""Hostile SSP archives are refused with E017 and nothing lands outside the extraction folder."""

from __future__ import annotations

import io
import stat
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.frontends import load_system
from fmionnx.spec.ssp_archive import cache_root, file_digest
from tests.ssp.test_import import gain, ssd

VALID_SSD = ssd(f"<ssd:Elements>{gain('a')}</ssd:Elements>")


def _zip(path: Path, add: Callable[[zipfile.ZipFile], None]) -> Path:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("SystemStructure.ssd", VALID_SSD)
        add(archive)
    return path


def _traversal(archive: zipfile.ZipFile) -> None:
    archive.writestr("../../escaped.txt", "owned")


def _absolute(archive: zipfile.ZipFile) -> None:
    archive.writestr("/fmionnx-escaped-absolute.txt", "owned")


def _symlink(archive: zipfile.ZipFile) -> None:
    info = zipfile.ZipInfo("resources/link")
    info.external_attr = (stat.S_IFLNK | 0o777) << 16
    archive.writestr(info, "../../outside")


def _bomb(archive: zipfile.ZipFile) -> None:
    archive.writestr("resources/zeros.bin", b"\0" * (64 * 1024**2))


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (_traversal, "outside the archive"),
        (_absolute, "absolute path"),
        (_symlink, "symbolic link"),
        (_bomb, "zip bomb"),
    ],
    ids=["dotdot", "absolute", "symlink", "zip-bomb"],
)
def test_hostile_ssp_is_refused_with_e017_and_writes_nothing_outside(
    tmp_path: Path, make, message: str
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    archive = _zip(work / "hostile.ssp", make)
    before = set(tmp_path.rglob("*"))
    bag = DiagnosticBag()
    loaded = load_system(archive, bag)
    assert loaded.spec is None
    codes = [(d.code, d.message) for d in bag]
    assert len(codes) == 1
    assert codes[0][0] == "E017"
    assert message in codes[0][1]
    assert set(tmp_path.rglob("*")) == before
    assert not Path("/fmionnx-escaped-absolute.txt").exists()
    # No half-filled cache entry and no staging folder are left behind.
    root = cache_root()
    assert not (root / file_digest(archive)[:24]).exists()
    assert not list(root.glob(".unpack-*"))


def test_corrupt_ssp_is_e012(tmp_path: Path) -> None:
    archive = tmp_path / "corrupt.ssp"
    archive.write_bytes(b"PK\x03\x04 this is not really a zip")
    bag = DiagnosticBag()
    assert load_system(archive, bag).spec is None
    assert [d.code for d in bag] == ["E012"]


def test_hostile_fmu_inside_an_ssp_is_refused(tmp_path: Path) -> None:
    fmu = io.BytesIO()
    with zipfile.ZipFile(fmu, "w") as inner:
        inner.writestr("modelDescription.xml", "<fmiModelDescription/>")
        inner.writestr("../../../fmu-escaped.txt", "owned")
    body = f"<ssd:Elements>{gain('a')}</ssd:Elements>"
    archive = tmp_path / "fmu.ssp"
    with zipfile.ZipFile(archive, "w") as outer:
        outer.writestr(
            "SystemStructure.ssd", ssd(body, after='<ssd:DefaultExperiment stopTime="1"/>')
        )
        outer.writestr("resources/Gain.fmu", fmu.getvalue())
    result = api.compile_system(archive)
    e017 = [d for d in result.diagnostics if d.code == "E017"]
    assert e017, result.diagnostics
    assert "outside" in e017[0].message
    assert not any(p.name == "fmu-escaped.txt" for p in tmp_path.parent.rglob("fmu-escaped.txt"))


def test_an_archive_naming_one_member_twice_is_refused(tmp_path: Path) -> None:
    """Unzippers disagree on which of two equal names they read: the SSD would be ambiguous."""
    archive = tmp_path / "twice.ssp"
    with pytest.warns(UserWarning, match="Duplicate name"):
        _zip(archive, lambda zipped: zipped.writestr("SystemStructure.ssd", ssd("")))
    bag = DiagnosticBag()
    assert load_system(archive, bag).spec is None
    assert [(d.code, d.message) for d in bag] == [
        ("E017", "`twice.ssp`: the archive holds two members named `SystemStructure.ssd`")
    ]
    assert not (cache_root() / file_digest(archive)[:24]).exists()
