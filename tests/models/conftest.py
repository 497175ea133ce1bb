"""Fixtures of the reference-model tests: the scripts in models/ and benchmarks/ as modules."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

import pytest

from tests.conftest import REPO

# Headless rendering; must be set before mujoco is first imported.
os.environ.setdefault("MUJOCO_GL", "egl")


def load_script(path: Path) -> ModuleType:
    """Import a script that is not part of a package (models/*.py, benchmarks/*.py)."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def measure_detector() -> ModuleType:
    return load_script(REPO / "models" / "measure_detector.py")


@pytest.fixture(scope="session")
def detector_builder() -> ModuleType:
    return load_script(REPO / "models" / "onnx" / "build_sign_detector.py")


@pytest.fixture(scope="session")
def handwritten_loop() -> ModuleType:
    return load_script(REPO / "benchmarks" / "handwritten_sign_follower.py")
