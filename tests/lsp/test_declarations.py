"""The copies made for editors stay in their place: a packed FMU's model description is
copied byte for byte, read-only, into the cache; a link planted at the copy's name is
replaced, its target untouched."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.lsp.declarations import CACHE_NAME, model_description_file


def test_a_packed_model_description_is_copied_and_a_planted_link_replaced(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    fmu = tmp_path / "Gain.fmu"
    fmu.write_bytes(fixture_fmu("Gain").read_bytes())
    interface = COMPONENT_KINDS["fmu"].read_interface(fmu, None)
    with zipfile.ZipFile(fmu) as archive:
        member = archive.read("modelDescription.xml")
    copy = model_description_file(interface)
    assert copy is not None
    assert copy.is_relative_to(tmp_path / "cache" / CACHE_NAME)
    assert copy.read_bytes() == member
    assert copy.stat().st_mode & 0o777 == 0o444
    victim = tmp_path / "victim.xml"
    victim.write_text("the user's file", encoding="utf-8")
    victim.chmod(0o644)
    copy.unlink()
    copy.symlink_to(victim)
    again = model_description_file(interface)
    assert again == copy
    assert not copy.is_symlink()
    assert copy.read_bytes() == member
    assert victim.read_text(encoding="utf-8") == "the user's file"
    assert victim.stat().st_mode & 0o777 == 0o644
