"""Helpers for runtime tests: system files written next to the real test models."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from fmionnx.runtime import guardian
from fmionnx.runtime.guardian import _Shared, _SharedTracks

SystemWriter = Callable[[str], Path]


@pytest.fixture
def write_system(tmp_path: Path) -> SystemWriter:
    """``write_system(yaml_text)`` -> path of ``system.yaml`` in a fresh folder."""

    def write(text: str) -> Path:
        path = tmp_path / "system.yaml"
        path.write_text(text, encoding="utf-8")
        return path

    return write


@pytest.fixture
def shared() -> Iterator[_Shared]:
    """The guardian's shared memory, registered as in the forked child (closed afterwards)."""
    memory = _Shared()
    guardian._REGISTRY[:] = [_SharedTracks(memory)]  # as in the forked child
    try:
        yield memory
    finally:
        guardian._REGISTRY[:] = []
        memory.close()
