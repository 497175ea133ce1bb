"""``fmionnx validate MODEL``: a lone FMU, ONNX model or MuJoCo scene is checked (issue #16).

A good model passes (exit 0); a model that fails FMPy's validation, lacks the library a run
would load, fails the ONNX checker or strict shape inference, or is not a model at all gives a
diagnostic with a code at the file (exit 1), never a traceback.
"""

from __future__ import annotations

import json
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import REPO, built_model


def validate(*args: str | Path) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["validate", *map(str, args)], env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def rewrite_fmu(
    source: Path, target: Path, change: Callable[[str, bytes], tuple[str, bytes]]
) -> Path:
    """A copy of the FMU ``source`` with every member passed through ``change(name, data)``."""
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w") as new:
        for info in old.infolist():
            if not info.is_dir():
                new.writestr(*change(info.filename, old.read(info)))
    return target


def onnx_model(path: Path, nodes: list[onnx.NodeProto], shape_y: list[int]) -> Path:
    graph = helper.make_graph(
        nodes,
        "g",
        [
            helper.make_tensor_value_info("a", TensorProto.FLOAT, [2]),
            helper.make_tensor_value_info("b", TensorProto.FLOAT, [3]),
        ],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, shape_y)],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


@pytest.fixture
def gain(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> Path:
    monkeypatch.chdir(tmp_path)
    return Path(shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu"))


@pytest.mark.parametrize(
    "model",
    [
        REPO / "build" / "models" / "ReadOdometry.fmu",
        REPO / "build" / "models" / "SignTrackingLogic3.fmu",
        REPO / "build" / "models" / "sign_detector.onnx",
        REPO / "models" / "world" / "sign_course.xml",
        REPO / "tests" / "fixtures" / "scenes" / "rover.xml",
    ],
    ids=lambda p: p.name,
)
def test_the_projects_models_pass(model: Path) -> None:
    built_model("ReadOdometry.fmu")  # a `make models` hint when the models are missing
    assert validate(model) == (0, "no problems in 1 file\n")


def test_an_fmu_failing_fmpys_validation_is_e019(gain: Path) -> None:
    def drop_an_output_from_the_model_structure(name: str, data: bytes) -> tuple[str, bytes]:
        if name == "modelDescription.xml":
            data = data.replace(b'      <Unknown index="7" dependencies="4"/>\n', b"", 1)
        return name, data

    def bad_name(name: str, data: bytes) -> tuple[str, bytes]:
        if name == "modelDescription.xml":
            data = data.replace(b'name="k"', b'name="k k"')
        return name, data

    rewrite_fmu(gain, Path("Unstructured.fmu"), drop_an_output_from_the_model_structure)
    rewrite_fmu(gain, Path("BadName.fmu"), bad_name)
    code, output = validate("Unstructured.fmu", "BadName.fmu")
    assert code == 1
    assert output.splitlines() == [
        "Unstructured.fmu: error[E019 invalid-model]: FMPy: ModelStructure/Outputs must have "
        'exactly one entry for each variable with causality="output".',
        'BadName.fmu: error[E019 invalid-model]: FMPy: "k k" (line 38) is not a legal variable '
        "name for naming convention \"structured\". No terminal matches ' ' in the current "
        "parser context, at line 1 col 2",
        "2 errors in 2 files",
    ]


def test_an_fmu_whose_library_is_not_named_after_its_model_identifier_is_e015(
    gain: Path,
) -> None:
    def rename_library(name: str, data: bytes) -> tuple[str, bytes]:
        return name.replace("linux64/Gain.so", "linux64/Other.so"), data

    rewrite_fmu(gain, Path("Renamed.fmu"), rename_library)
    code, output = validate("Renamed.fmu")
    assert code == 1
    assert output.splitlines() == [
        "Renamed.fmu: error[E015 no-binary]: `binaries/linux64/` has no `Gain.so`, the library "
        "of the model identifier `Gain` (co-simulation)",
        "  hint: re-export the FMU; the binary's name must be the model identifier",
        "Renamed.fmu: error[E015 no-binary]: `binaries/linux64/` has no `Gain.so`, the library "
        "of the model identifier `Gain` (model exchange)",
        "  hint: re-export the FMU; the binary's name must be the model identifier",
        "2 errors in 1 file",
    ]


def test_a_corrupt_fmu_is_one_error_at_the_file_without_run_settings(gain: Path) -> None:
    Path("Broken.fmu").write_bytes(gain.read_bytes()[:300])
    code, output = validate("Broken.fmu")
    assert code == 1
    lines = output.splitlines()
    assert lines[0].startswith("Broken.fmu: error[E012 bad-model]: `")
    assert lines[0].endswith("Broken.fmu` is not a zip archive (corrupt or not an FMU/SSP)")
    assert lines[1:] == ["1 error in 1 file"]
    assert "Traceback" not in output


def test_an_onnx_model_failing_the_checker_is_e019(tmp_path: Path) -> None:
    path = onnx_model(tmp_path / "dangling.onnx", [helper.make_node("Add", ["a", "c"], ["y"])], [2])
    code, output = validate(path)
    assert code == 1
    first = output.splitlines()[0]
    assert first.startswith(
        f"{path}: error[E019 invalid-model]: the ONNX checker refuses the model: "
    )
    assert "'c'" in first
    assert output.endswith("1 error in 1 file\n")


def test_an_onnx_model_failing_strict_shape_inference_is_e019(tmp_path: Path) -> None:
    path = onnx_model(tmp_path / "shapes.onnx", [helper.make_node("Add", ["a", "b"], ["y"])], [2])
    code, output = validate(path)
    assert code == 1
    first = output.splitlines()[0]
    assert first.startswith(f"{path}: error[E019 invalid-model]: ONNX shape inference fails: ")
    assert output.endswith("1 error in 1 file\n")


def test_a_broken_mujoco_scene_is_e012_at_the_file(tmp_path: Path) -> None:
    scene = tmp_path / "scene.xml"
    scene.write_text("<mujoco><worldbody><geom type='sphere'/></worldbody>\n", encoding="utf-8")
    code, output = validate(scene)
    assert code == 1
    assert output.splitlines()[0].startswith(f"{scene}: error[E012 bad-model]: ")
    assert "Traceback" not in output


def test_models_and_systems_mix_and_every_format_works(gain: Path) -> None:
    shutil.copy(REPO / "tests" / "fixtures" / "scenes" / "rover.xml", "rover.xml")
    code, output = validate("Gain.fmu", "rover.xml", "--format", "json")
    assert code == 0
    report = json.loads(output)
    assert [f["path"] for f in report["files"]] == ["Gain.fmu", "rover.xml"]


def test_a_file_that_is_neither_a_system_nor_a_model_is_still_e013(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("hello\n", encoding="utf-8")
    code, output = validate(notes)
    assert code == 1
    assert "error[E013 unsupported-model]: `notes.txt` is not a system file fmionnx reads" in output
    assert "hint: system files end in `.ssd`, `.ssp`, `.yaml`, `.yml`" in output


def test_run_of_a_corrupt_fmu_reports_only_that(gain: Path) -> None:
    Path("Broken.fmu").write_bytes(gain.read_bytes()[:300])
    result = CliRunner().invoke(app, ["run", "Broken.fmu"], env={"COLUMNS": "1000"})
    assert result.exit_code == 1
    assert "E012 bad-model" in result.output
    assert "E004" not in result.output  # no stop time to complain about: the FMU is unreadable
    assert not Path("out").exists()
