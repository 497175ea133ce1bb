"""FMU interfaces kept in the cache folder (``fmionnx.kinds.fmu.keptinterface``): the same
interface as read with fmpy, a tampered entry ignored, an unpacked FMU folder never kept,
and a compile of an unchanged FMU that does not import fmpy."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.fmu import keptinterface
from fmionnx.kinds.fmu.kind import FMU_KIND, load_fmu_interface
from tests.keptstores import entries, forge


def _entries() -> list[Path]:
    return entries(keptinterface.STORE)


def _fresh(path: Path):  # type: ignore[no-untyped-def]
    clear_cache()  # as a new process: nothing read yet in this one
    return FMU_KIND.read_interface(path, None)


@pytest.mark.parametrize("name", ["Gain", "Vector3", "Integrator"])
def test_a_kept_interface_is_the_one_fmpy_gives(
    name: str, fixture_fmu: Callable[[str], Path], tmp_path: Path
) -> None:
    path = tmp_path / f"{name}.fmu"
    shutil.copy(fixture_fmu(name), path)
    expected = load_fmu_interface(path)
    assert _fresh(path) == expected  # read, and kept
    assert len(_entries()) == 1
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    shutil.copy(path, moved / path.name)
    kept = _fresh(moved / path.name)  # the same bytes and name elsewhere: kept, this path
    assert kept.path == moved / path.name
    assert kept == load_fmu_interface(moved / path.name)
    assert len(_entries()) == 1


def test_a_tampered_entry_is_ignored(fixture_fmu: Callable[[str], Path], tmp_path: Path) -> None:
    path = tmp_path / "Gain.fmu"
    shutil.copy(fixture_fmu("Gain"), path)
    expected = _fresh(path)
    (entry,) = _entries()
    forge(entry, b'"name":"k"', b'"name":"q"')
    assert _fresh(path) == expected


def test_an_unpacked_fmu_is_never_kept(fixture_fmu: Callable[[str], Path], tmp_path: Path) -> None:
    folder = tmp_path / "Gain"
    with zipfile.ZipFile(fixture_fmu("Gain")) as archive:
        archive.extractall(folder)
    assert _fresh(folder).port("k") is not None
    assert _entries() == []


def test_switched_off_nothing_is_kept(
    fixture_fmu: Callable[[str], Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(keptinterface.STORE.switch, "0")
    path = tmp_path / "Gain.fmu"
    shutil.copy(fixture_fmu("Gain"), path)
    _fresh(path)
    assert _entries() == []


CHECK = """
import sys
from pathlib import Path
from fmionnx.kinds.fmu.kind import FMU_KIND
assert FMU_KIND.read_interface(Path(sys.argv[1]), None).port("k") is not None
print("fmpy" in sys.modules)
"""


def test_an_unchanged_fmu_is_read_without_fmpy(fixture_fmu: Callable[[str], Path]) -> None:
    runs = [
        subprocess.run(
            [sys.executable, "-c", CHECK, str(fixture_fmu("Gain"))],
            env=dict(os.environ), capture_output=True, text=True, check=True,
        ).stdout.strip()
        for _ in range(2)
    ]  # fmt: skip
    assert runs == ["True", "False"]


def test_an_interface_read_from_other_bytes_than_the_key_hashed_is_not_kept(
    fixture_fmu: Callable[[str], Path], tmp_path: Path
) -> None:
    """The archive rebuilt between the key's hash and the read: the new bytes' interface
    must not be kept under the old bytes' key."""
    path = tmp_path / "Gain.fmu"
    shutil.copy(fixture_fmu("Gain"), path)

    def rebuilt_meanwhile():  # type: ignore[no-untyped-def]
        shutil.copy(fixture_fmu("Integrator"), path)
        return load_fmu_interface(path)

    clear_cache()
    read = keptinterface.kept_interface(path, rebuilt_meanwhile)
    assert {p.name for p in read.ports} >= {"x"}  # Integrator's, read from the new bytes
    assert _entries() == []
