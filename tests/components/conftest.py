"""Fixtures of the component-reader tests: ONNX models written once per session."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from tests.conftest import FIXTURES


@pytest.fixture(scope="session")
def onnx_models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """name -> path of every model of ``tests/fixtures/onnx/build_models.py``."""
    script = FIXTURES / "onnx" / "build_models.py"
    spec = importlib.util.spec_from_file_location("fmionnx_test_onnx_models", script)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    paths: dict[str, Path] = module.write_all(tmp_path_factory.mktemp("onnx"))
    return paths


@pytest.fixture(scope="session")
def rover_scene() -> Path:
    """A MuJoCo scene with named and unnamed sensors, actuators, sites and cameras."""
    return FIXTURES / "scenes" / "rover.xml"
