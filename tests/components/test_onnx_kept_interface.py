"""ONNX interfaces kept in the cache folder (``fmionnx.kinds.onnx.keptinterface``): the same
interface as read with ``onnx``, a tampered entry ignored, a model with external data never
kept, and a compile of an unchanged model that does not import ``onnx``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import onnx
import pytest

from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.onnx import keptinterface
from fmionnx.kinds.onnx.interface import read_onnx_interface, read_signature
from tests.conftest import built_model
from tests.fixtures.onnx.build_models import scale
from tests.keptstores import entries, forge
from tests.security.test_onnx_files import WEIGHTS, _scale


def _entries() -> list[Path]:
    return entries(keptinterface.STORE)


def _fresh(path: Path):  # type: ignore[no-untyped-def]
    clear_cache()  # as a new process: nothing read yet in this one
    return read_onnx_interface(path)


@pytest.mark.parametrize("which", ["detector", "scale"])
def test_a_kept_interface_is_the_one_onnx_gives(which: str, tmp_path: Path) -> None:
    if which == "detector":
        path = tmp_path / "detector.onnx"
        shutil.copy(built_model("sign_detector.onnx"), path)
    else:
        path = tmp_path / "scale.onnx"
        onnx.save(scale(), path)
    expected, external = read_signature(path)
    assert not external
    assert _fresh(path) == expected  # read, and kept
    assert len(_entries()) == 1
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    shutil.copy(path, moved / path.name)
    kept = _fresh(moved / path.name)  # the same bytes and name elsewhere: kept, this path
    assert kept.path == moved / path.name
    assert kept == read_signature(moved / path.name)[0]
    assert len(_entries()) == 1


def test_a_tampered_entry_is_ignored(tmp_path: Path) -> None:
    path = tmp_path / "scale.onnx"
    onnx.save(scale(), path)
    expected = _fresh(path)
    (entry,) = _entries()
    forge(entry, b'"x scaled element-wise"', b'"forged"')
    assert _fresh(path) == expected


def test_a_model_with_external_data_is_never_kept(tmp_path: Path) -> None:
    path = tmp_path / "scale.onnx"
    model = _scale("w.bin")
    (tmp_path / "w.bin").write_bytes(WEIGHTS.tobytes())
    path.write_bytes(model.SerializeToString())
    assert read_signature(path)[1]
    _fresh(path)
    assert _entries() == []


def test_switched_off_nothing_is_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(keptinterface.STORE.switch, "0")
    path = tmp_path / "scale.onnx"
    onnx.save(scale(), path)
    _fresh(path)
    assert _entries() == []


CHECK = """
import sys
from pathlib import Path
from fmionnx.kinds.onnx.interface import read_onnx_interface
assert read_onnx_interface(Path(sys.argv[1])).port("image") is not None
print("onnx" in sys.modules)
"""


def test_an_unchanged_model_is_read_without_onnx() -> None:
    model = str(built_model("sign_detector.onnx"))
    runs = [
        subprocess.run(
            [sys.executable, "-c", CHECK, model],
            env=dict(os.environ), capture_output=True, text=True, check=True,
        ).stdout.strip()
        for _ in range(2)
    ]  # fmt: skip
    assert runs == ["True", "False"]
