"""Helpers for runtime tests: system files written next to the real test models."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

SystemWriter = Callable[[str], Path]


@pytest.fixture
def write_system(tmp_path: Path) -> SystemWriter:
    """``write_system(yaml_text)`` -> path of ``system.yaml`` in a fresh folder."""

    def write(text: str) -> Path:
        path = tmp_path / "system.yaml"
        path.write_text(text, encoding="utf-8")
        return path

    return write
