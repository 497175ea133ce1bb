"""The compile cache for a lone model (``fmionnx run model.fmu``, ``fmionnx.load("m.onnx")``):
read back while the model and the run's settings are unchanged, compiled again otherwise,
never kept with errors, and the same results either way."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from fmionnx.compile import single
from fmionnx.compile.ir import Origin
from fmionnx.core.errors import DiagnosticError
from fmionnx.pipeline import compilecache
from fmionnx.pipeline.system import check_model, load
from tests.conftest import build_fixture_fmu, let_files_settle
from tests.pipeline.test_compile_cache import assert_same_results_off_missed_and_hit, resign


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The Integrator fixture FMU in a folder of its own, run from there; the cache in
    ``tmp_path / cache``, switched on."""
    here = tmp_path / "models"
    here.mkdir()
    shutil.copy(build_fixture_fmu("Integrator"), here / "Integrator.fmu")
    let_files_settle()
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv(compilecache.SWITCH, "1")
    monkeypatch.chdir(here)
    return here


def _counted(monkeypatch: pytest.MonkeyPatch, name: str) -> list[Path]:
    """The models the function ``name`` of :mod:`fmionnx.compile.single` is called for."""
    seen: list[Path] = []
    real = getattr(single, name)

    def counting(path: Path, *args: Any, **kwargs: Any) -> Any:
        seen.append(path)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(single, name, counting)
    return seen


@pytest.fixture
def compiles(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """Every real compile of a lone model in this process."""
    return _counted(monkeypatch, "compile_single_model")


def entries(tmp_path: Path) -> list[Path]:
    root = tmp_path / "cache" / "compiled"
    if not root.exists():
        return []
    return sorted(p / compilecache.ENTRY for p in root.iterdir() if not p.name.startswith("."))


def test_an_unchanged_fmu_is_read_back_equal(folder: Path, compiles: list[Path]) -> None:
    first = load("Integrator.fmu")
    second = load("Integrator.fmu")
    assert len(compiles) == 1
    assert second.compiled == first.compiled
    assert second.diagnostics == first.diagnostics
    assert second.aliases == first.aliases
    assert second.record == first.record
    assert second.aliases  # a lone FMU's columns are named by its variables, read back too


def test_results_are_the_same_with_and_without_the_cache(
    folder: Path, compiles: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert_same_results_off_missed_and_hit("Integrator.fmu", compiles, monkeypatch, stop_time=0.5)


def test_a_changed_model_compiles_again(folder: Path, compiles: list[Path]) -> None:
    first = load("Integrator.fmu")
    shutil.copy(build_fixture_fmu("Gain"), folder / "Integrator.fmu")
    let_files_settle()
    second = load("Integrator.fmu")
    assert len(compiles) == 2
    assert second.compiled != first.compiled
    load("Integrator.fmu")
    assert len(compiles) == 2  # the new model's compile is kept in turn


def test_a_link_pointed_at_another_model_compiles_again(folder: Path, compiles: list[Path]) -> None:
    """The compiled system names the model by the path it resolves to: a link pointed
    elsewhere must not read back the system of the model it named before."""
    shutil.copy(build_fixture_fmu("Gain"), folder / "Gain.fmu")
    let_files_settle()
    link = folder / "model.fmu"
    link.symlink_to("Integrator.fmu")
    first = load("model.fmu")
    link.unlink()
    link.symlink_to("Gain.fmu")
    second = load("model.fmu")
    assert len(compiles) == 2
    assert second.compiled.components[0].path == folder / "Gain.fmu"
    assert first.compiled.components[0].path == folder / "Integrator.fmu"


def test_a_model_rebuilt_during_its_compile_is_not_kept(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The entry would pair the old model's compile with the new model's hash: the next run
    would read the old ports back and run them against the new library."""
    real = single.compile_single_model
    calls: list[Path] = []

    def rebuilt_meanwhile(path: Path, *args: Any, **kwargs: Any) -> Any:
        compiled = real(path, *args, **kwargs)
        if not calls:
            shutil.copy(build_fixture_fmu("Gain"), folder / "Integrator.fmu")
        calls.append(path)
        return compiled

    monkeypatch.setattr(single, "compile_single_model", rebuilt_meanwhile)
    first = load("Integrator.fmu")
    second = load("Integrator.fmu")
    assert len(calls) == 2  # not read back: compiled again, from the model now there
    assert second.compiled != first.compiled
    assert "k" in {p.name for p in second.compiled.components[0].interface.ports}


def test_a_link_pointed_elsewhere_during_the_compile_never_serves_the_wrong_model(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Pointed at Gain after its entry's key was worked out (for Integrator) and before the
    compile resolved it: Gain's system must never be read back for Integrator."""
    shutil.copy(build_fixture_fmu("Gain"), folder / "Gain.fmu")
    let_files_settle()
    link = folder / "model.fmu"
    link.symlink_to("Integrator.fmu")
    real = single.compile_single_model
    calls: list[Path] = []

    def repointed_meanwhile(path: Path, *args: Any, **kwargs: Any) -> Any:
        if not calls:
            link.unlink()
            link.symlink_to("Gain.fmu")
        calls.append(path)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(single, "compile_single_model", repointed_meanwhile)
    assert load("model.fmu").compiled.components[0].path == folder / "Gain.fmu"
    link.unlink()
    link.symlink_to("Integrator.fmu")
    again = load("model.fmu")
    assert again.compiled.components[0].path == folder / "Integrator.fmu"
    assert len(calls) == 2


def test_an_upper_case_suffix_and_an_unpacked_fmu_are_kept_too(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    import zipfile

    shutil.copy(folder / "Integrator.fmu", folder / "Shouting.FMU")
    with zipfile.ZipFile(folder / "Integrator.fmu") as archive:
        archive.extractall(folder / "Unpacked.fmu")
    let_files_settle()
    for name in ("Shouting.FMU", "Unpacked.fmu"):
        first = load(name)
        assert load(name).compiled == first.compiled
    assert len(compiles) == 2
    # A file changed inside the unpacked FMU is a change of the model.
    (folder / "Unpacked.fmu" / "documentation.txt").write_text("new", encoding="utf-8")
    let_files_settle()
    load("Unpacked.fmu")
    assert len(compiles) == 3


def test_each_interface_reads_back_its_own_compile(folder: Path, compiles: list[Path]) -> None:
    me = load("Integrator.fmu", interface="me")
    cs = load("Integrator.fmu", interface="cs")
    assert me.compiled != cs.compiled
    assert load("Integrator.fmu", interface="me").compiled == me.compiled
    assert load("Integrator.fmu", interface="cs").compiled == cs.compiled
    assert len(compiles) == 2


def test_each_setting_is_an_entry_of_its_own(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    load("Integrator.fmu")
    load("Integrator.fmu", step=0.05)
    load("Integrator.fmu", start=0.5)
    load("Integrator.fmu", interface="cs")
    load(folder / "Integrator.fmu")  # another path as given: its diagnostics name it so
    assert len(compiles) == 5
    assert len(entries(tmp_path)) == 5
    stepped = load("Integrator.fmu", step=0.05)
    assert len(compiles) == 5
    assert stepped.compiled.run.step == 0.05
    assert dict(stepped.compiled.run.origins)["step"] is Origin.COMMAND_LINE


def test_a_model_with_errors_is_never_kept(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    (folder / "Broken.fmu").write_bytes(b"not a zip")
    for _ in range(2):
        with pytest.raises(DiagnosticError):
            load("Broken.fmu")
    assert len(compiles) == 2
    assert entries(tmp_path) == []


def _doubling_model(path: Path) -> Path:
    """y = 2 x, one float."""
    import onnx
    from onnx import TensorProto, helper

    two = helper.make_tensor("two", TensorProto.FLOAT, [1], [2.0])
    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "two"], ["y"])],
        "double",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
        [two],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


def test_an_onnx_model_is_kept_too(folder: Path, compiles: list[Path]) -> None:
    model = _doubling_model(folder / "double.onnx")
    let_files_settle()
    first = load(model)
    second = load(model)
    assert len(compiles) == 1
    assert second.compiled == first.compiled


def test_switched_off_it_neither_reads_nor_writes(
    folder: Path, compiles: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(compilecache.SWITCH, "0")
    load("Integrator.fmu")
    load("Integrator.fmu")
    assert len(compiles) == 2
    assert entries(tmp_path) == []


def test_an_entry_naming_a_model_no_lookup_hashed_is_refused(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    """Signed with the user's own key (a bug would do that): still refused, since the model
    it would run is not one whose contents the lookup just checked."""

    def forget_the_model(data: dict[str, object]) -> None:
        listed = data["dependencies"]
        assert isinstance(listed, list)
        data["dependencies"] = [d for d in listed if not d[0].endswith(".fmu")]

    load("Integrator.fmu")
    (entry,) = entries(tmp_path)
    resign(entry, forget_the_model)
    load("Integrator.fmu")
    assert len(compiles) == 2


# -- fmionnx validate MODEL -----------------------------------------------------------------------


@pytest.fixture
def checks(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """Every real check of a lone model (``fmionnx validate MODEL``) in this process."""
    return _counted(monkeypatch, "check_single_model")


def test_an_unchanged_model_s_check_is_read_back(
    folder: Path, checks: list[Path], compiles: list[Path]
) -> None:
    first = check_model("Integrator.fmu")
    second = check_model("Integrator.fmu")
    assert len(checks) == 1
    assert first.ok
    assert second == first
    load("Integrator.fmu")  # a run's compile is another entry: its settings differ
    assert len(compiles) == 1


def test_a_check_that_found_an_error_is_made_every_time(
    folder: Path, checks: list[Path], tmp_path: Path
) -> None:
    (folder / "Broken.fmu").write_bytes(b"not a zip")
    assert not check_model("Broken.fmu").ok
    assert not check_model("Broken.fmu").ok
    assert len(checks) == 2
    assert entries(tmp_path) == []


def test_a_changed_model_is_checked_again(folder: Path, checks: list[Path]) -> None:
    first = check_model("Integrator.fmu")
    shutil.copy(build_fixture_fmu("Gain"), folder / "Integrator.fmu")
    second = check_model("Integrator.fmu")
    assert len(checks) == 2
    assert second.system != first.system


# -- what is never kept ---------------------------------------------------------------------------


def test_a_scene_changed_while_it_is_checked_is_checked_again(
    folder: Path, checks: list[Path]
) -> None:
    """A scene is not hashed by its interface (its includes and assets count too): what
    tells is that one of its files changed after the check began."""
    from tests.conftest import REPO

    scene = folder / "rover.xml"
    shutil.copy(REPO / "tests" / "fixtures" / "scenes" / "rover.xml", scene)
    let_files_settle()
    real = single.check_single_model

    def edited_meanwhile(path: Path, *args: Any, **kwargs: Any) -> Any:
        result = real(path, *args, **kwargs)
        if not calls:
            scene.write_text(scene.read_text(encoding="utf-8") + "\n", encoding="utf-8")
        calls.append(path)
        return result

    calls: list[Path] = []
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(single, "check_single_model", edited_meanwhile)
        assert check_model(scene).ok
        let_files_settle()
        assert check_model(scene).ok
        assert check_model(scene).ok
    assert len(calls) == 2  # the edited scene was checked again, and kept then


def test_an_onnx_model_with_external_data_is_read_every_time(
    folder: Path, compiles: list[Path], checks: list[Path], tmp_path: Path
) -> None:
    """Its tensor files are not hashed with it (a link put in their place must meet E017 at
    the next validate): neither its compile nor its check is kept."""
    from tests.security.test_onnx_files import WEIGHTS, _scale

    (folder / "w.bin").write_bytes(WEIGHTS.tobytes())
    (folder / "scale.onnx").write_bytes(_scale("w.bin").SerializeToString())
    let_files_settle()
    for _ in range(2):
        load("scale.onnx")
        assert check_model("scale.onnx").ok
    assert (len(compiles), len(checks)) == (2, 2)
    assert entries(tmp_path) == []
    assert load("scale.onnx").compiled.components[0].interface.fact("externalData") == "true"


def test_validate_reports_the_same_read_back_as_checked_afresh(
    folder: Path, tmp_path: Path
) -> None:
    def validate(*args: str, cache: str) -> tuple[int, str]:
        done = subprocess.run(
            [sys.executable, "-m", "fmionnx", "validate", "Integrator.fmu", "double.onnx", *args],
            capture_output=True, text=True, check=False, timeout=120,
            env={**os.environ, compilecache.SWITCH: cache},
        )  # fmt: skip
        return done.returncode, done.stdout

    _doubling_model(folder / "double.onnx")
    let_files_settle()
    for args in (("--format", "json"), ("--format", "sarif"), ()):
        afresh = validate(*args, cache="0")
        assert afresh[0] == 0
        assert validate(*args, cache="1") == afresh  # checked, and kept
        assert validate(*args, cache="1") == afresh  # read back
    assert len(entries(tmp_path)) == 2
