"""Zip archives are bounded as a whole: members, unpacked size, compression ratio.

The limits used to apply to single members above 1 MiB only, so a few hundred kilobytes of
many small members of zeros unpacked to hundreds of megabytes per run. Each test builds its own
archive with ``zipfile``.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.archive import RATIO_FLOOR_BYTES, safe_extract
from fmionnx.core.errors import ModelError
from fmionnx.kinds.fmu.kind import FMU_KIND
from tests.components.fmi_xml import fmi2, scalar

DESCRIPTION = fmi2([scalar("u", 0, "input")]).encode()


def _archive(path: Path, members: dict[str, bytes], *, stored: bool = False) -> Path:
    method = zipfile.ZIP_STORED if stored else zipfile.ZIP_DEFLATED
    with zipfile.ZipFile(path, "w", compression=method) as archive:
        archive.writestr("modelDescription.xml", DESCRIPTION)
        for name, data in members.items():
            archive.writestr(name, data)
    return path


def _small_zeros(path: Path, count: int = 24) -> Path:
    """``count`` members of 512 KiB zeros each: every one below the old 1 MiB threshold."""
    chunk = bytes(512 * 1024)
    return _archive(path, {f"resources/part{i:03}.bin": chunk for i in range(count)})


def test_many_small_members_of_zeros_are_a_bomb(tmp_path: Path) -> None:
    path = _small_zeros(tmp_path / "small-bomb.fmu")
    assert all(i.file_size < RATIO_FLOOR_BYTES for i in zipfile.ZipFile(path).infolist())
    with pytest.raises(ModelError, match=r"archive expands \d+x") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert "FMIONNX_MAX_COMPRESSION_RATIO" in (info.value.hint or "")
    target = tmp_path / "out"
    with pytest.raises(ModelError, match="zip bomb"):
        safe_extract(path, target)
    assert not any(target.rglob("*.bin"))


def test_the_ratio_limit_can_be_raised(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _small_zeros(tmp_path / "zeros.fmu")
    monkeypatch.setenv("FMIONNX_MAX_COMPRESSION_RATIO", "100000")
    assert [p.name for p in FMU_KIND.read_interface(path, None).ports] == ["u"]


def test_member_count_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMIONNX_MAX_ARCHIVE_MEMBERS", "10")
    path = _archive(tmp_path / "many.fmu", {f"resources/{i}.txt": b"x" for i in range(10)})
    with pytest.raises(ModelError, match="11 members") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert "FMIONNX_MAX_ARCHIVE_MEMBERS" in (info.value.hint or "")


def test_total_unpacked_size_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMIONNX_MAX_ARCHIVE_BYTES", "100_000")
    noise = bytes(range(256)) * 400  # stored: ratio 1, 102400 bytes
    path = _archive(tmp_path / "big.fmu", {"resources/data.bin": noise}, stored=True)
    with pytest.raises(ModelError, match="expands to") as info:
        safe_extract(path, tmp_path / "out")
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert not (tmp_path / "out" / "resources" / "data.bin").exists()


def test_a_malformed_limit_setting_is_e008_not_ignored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMIONNX_MAX_ARCHIVE_MEMBERS", "lots")
    path = _archive(tmp_path / "ok.fmu", {})
    with pytest.raises(ModelError, match="FMIONNX_MAX_ARCHIVE_MEMBERS") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.RESOURCE_LIMIT


def test_real_fmus_stay_within_the_default_limits(fixture_fmu) -> None:  # type: ignore[no-untyped-def]
    for name in ("Gain", "Integrator", "Vector3"):
        assert FMU_KIND.read_interface(fixture_fmu(name), None).ports
