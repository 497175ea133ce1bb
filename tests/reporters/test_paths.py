from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.reporters.common import display_path


def test_paths_inside_the_working_directory_are_relative(tmp_path: Path) -> None:
    assert display_path(tmp_path / "sub" / ".." / "sub" / "b.yaml", tmp_path) == "sub/b.yaml"


def test_relative_paths_are_taken_from_the_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert display_path(Path("systems/a.yaml")) == "systems/a.yaml"


def test_paths_outside_the_working_directory_stay_absolute(tmp_path: Path) -> None:
    outside = tmp_path / "elsewhere" / "m.fmu"
    assert display_path(outside, tmp_path / "repo") == outside.as_posix()
