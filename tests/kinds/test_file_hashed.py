"""The kinds that declare ``FILE_HASHED`` carry the sha256 of the model file's bytes in the
interface they read: the compile cache keeps a compile only when the file it hashed for the
entry has that hash (a model rebuilt during the compile is not kept)."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.kinds.base import FILE_HASHED
from fmionnx.kinds.registry import COMPONENT_KINDS
from tests.conftest import REPO, build_fixture_fmu
from tests.pipeline.test_compile_cache_lone import _doubling_model

SYSTEM = """\
fmionnx: 1
name: hashed
run: {stop: 1, step: 0.5}
components:
  fmu: {kind: fmu, path: Integrator.fmu}
  net: {kind: onnx, path: double.onnx}
  table: {kind: signal, path: table.csv}
  world: {kind: mujoco, path: scene.xml}
"""


@pytest.fixture
def compiled(tmp_path: Path) -> dict[str, tuple[str, Path, str]]:
    """kind -> (content hash, model path, sha256 of the file) of one model of each kind."""
    shutil.copy(build_fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    _doubling_model(tmp_path / "double.onnx")
    (tmp_path / "table.csv").write_text("time,y\n0,1\n1,2\n", encoding="utf-8")
    shutil.copy(REPO / "tests" / "fixtures" / "scenes" / "rover.xml", tmp_path / "scene.xml")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    result = api.compile_system(tmp_path / "system.yaml")
    assert result.system is not None, result.diagnostics
    found = {}
    for component in result.system.components:
        digest = hashlib.sha256(component.path.read_bytes()).hexdigest()
        found[component.kind] = (component.interface.content_hash, component.path, digest)
    return found


def test_every_kind_that_says_so_hashes_its_file(
    compiled: dict[str, tuple[str, Path, str]],
) -> None:
    assert set(compiled) == set(COMPONENT_KINDS)  # one model of every kind was read
    for name, kind in COMPONENT_KINDS.items():
        if FILE_HASHED in kind.capabilities:
            content_hash, _, digest = compiled[name]
            assert content_hash == digest, name
    assert {n for n, k in COMPONENT_KINDS.items() if FILE_HASHED in k.capabilities} == {
        "fmu", "onnx", "signal",
    }  # fmt: skip
