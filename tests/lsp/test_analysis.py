"""The server's check of an open file, in-process: a keystroke reads no model again (the
compiler's interface cache, keyed by file identity), a model rebuilt on disk is read again,
and an unsaved buffer is what is checked."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.lsp.analysis import DocumentKind, analyse
from tests.conftest import built_model

SYSTEM = """\
fmionnx: 1
name: cached
run: {stop: 1, step: 0.1}
components:
  gain: {kind: fmu, path: Gain.fmu}
  detector: {kind: onnx, path: detector.onnx}
  src: {kind: signal, outputs: {a: {constant: 1}}}
connections:
  - src.a -> gain.u
"""


def test_a_keystroke_reads_no_model_again_and_a_rebuilt_model_is_read(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    import fmionnx.kinds.fmu.kind as fmu_kind
    import fmionnx.kinds.onnx.interface as onnx_interface

    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    shutil.copy(built_model("sign_detector.onnx"), tmp_path / "detector.onnx")
    reads: list[str] = []
    real_fmu, real_onnx = fmu_kind.load_fmu_interface, onnx_interface.read_signature

    def counted_fmu(path: Path):  # type: ignore[no-untyped-def]
        reads.append(path.name)
        return real_fmu(path)

    def counted_onnx(path: Path, data: bytes | None = None):  # type: ignore[no-untyped-def]
        reads.append(path.name)
        return real_onnx(path, data)

    monkeypatch.setattr(fmu_kind, "load_fmu_interface", counted_fmu)
    # an FMU touched but unchanged is served by its kept interface (its bytes are the same):
    # off here, to see this process's own cache follow the file's identity
    monkeypatch.setenv("FMIONNX_FMU_INTERFACES", "0")
    monkeypatch.setattr(onnx_interface, "read_signature", counted_onnx)
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM, encoding="utf-8")

    first = analyse(path, {path: SYSTEM})
    assert first.kind is DocumentKind.SYSTEM
    assert sorted(set(reads)) == ["Gain.fmu", "detector.onnx"]
    reads.clear()
    typed = SYSTEM.replace("src.a -> gain.u", "src.a -> gain.uu")
    second = analyse(path, {path: typed})
    assert [d.code for d in second.diagnostics if d.code.startswith("E")] == ["E021"]
    assert second.outline is not None
    assert second.outline.components["gain"].interface is not None
    assert reads == []  # every interface came from the cache
    stat = (tmp_path / "Gain.fmu").stat()
    os.utime(tmp_path / "Gain.fmu", ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    analyse(path, {path: typed})
    assert sorted(set(reads)) == ["Gain.fmu"]  # rebuilt (a new identity): read again


def test_the_outline_survives_a_mistake_in_one_entry(tmp_path: Path, fixture_fmu) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    text = SYSTEM.replace("path: Gain.fmu}", "path: Gain.fmu, perod: 2}").replace(
        "  detector: {kind: onnx, path: detector.onnx}\n", ""
    )
    path = tmp_path / "system.yaml"
    result = analyse(path, {path: text})
    assert [d.code for d in result.diagnostics] == ["E002"]  # `perod`: an unknown key
    assert result.outline is not None
    gain = result.outline.components["gain"]
    assert gain.interface is not None  # completion still knows the entry's ports
    assert gain.interface.port("u") is not None


def test_an_unsaved_study_is_checked_from_its_text(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    """A bug hunt: a new study file, not yet on disk, got one diagnostic "study file ...
    does not exist" and none of its real problems."""
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(
        "fmionnx: 1\nname: g\nrun: {stop: 1, step: 0.1}\n"
        "components:\n  gain: {kind: fmu, path: Gain.fmu}\n",
        encoding="utf-8",
    )
    study = tmp_path / "newstudy.yaml"  # never saved
    text = "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.kk: [1, 2]\n"
    analysis = analyse(study, {study: text})
    assert analysis.kind is DocumentKind.STUDY
    messages = [d.message for d in analysis.diagnostics if d.severity.name == "ERROR"]
    assert not [m for m in messages if "does not exist" in m], messages
    assert [m for m in messages if "kk" in m], messages
    assert not study.exists()
