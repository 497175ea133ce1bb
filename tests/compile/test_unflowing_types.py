"""Value types that do not flow per step, where a system file can still name them (a bug hunt).

String and binary connections and ``record:`` entries are E025 (tests/kinds/test_string_ports.py).
Two more places named such values:

* A system input (``inputs:``) is set once, before initialization, never during the run, so
  it reaches a string or binary port as a ``parameters:`` entry does, and that keeps working
  (an SSP string parameter connector becomes one). What could not work compiled: a
  ``factor``/``offset`` on such a target (every value was then refused when set), and a
  binary ``value`` that is no hexadecimal text (the run ended in a fault at t=0). Both are
  refused at compile time, where they are written.
* A ``record:`` entry naming an image (a MuJoCo camera, an ONNX ``uint8`` tensor), whole or by
  element, was left out of the results without a word. It is E025 at the entry.

``Strings2`` (FMI 2, ``text = label + "|" + textIn``) and ``Binary3`` (FMI 3, a binary
parameter ``blob`` described by ``blobSize``/``blobValue``) are real FMUs built from C.
"""

from __future__ import annotations

import re
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.runtime.result import RunStatus
from tests.conftest import FIXTURES, build_fixture_fmu

Found = tuple[str, str, int, int, str]  # severity, code, line, column, message


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path`` as the working directory, so messages name `system.yaml`."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def _write(folder: Path, fmu: str, rest: str) -> Path:
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: unflowing\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {build_fixture_fmu(fmu)}}}\n{rest}",
        encoding="utf-8",
    )
    return path


def _validate(path: Path) -> tuple[int, list[Found]]:
    result = CliRunner().invoke(app, ["validate", path.name])
    assert "Traceback" not in result.output
    pattern = r"^system\.yaml:(\d+):(\d+): (error|warning)\[(\w+) [\w-]+\]: (.*)$"
    found = [
        (severity, code, int(line), int(col), message)
        for line, col, severity, code, message in re.findall(
            pattern, result.output, flags=re.MULTILINE
        )
    ]
    return result.exit_code, found


# -- system inputs -------------------------------------------------------------------------------


def test_a_system_input_sets_string_ports_at_setup(folder: Path) -> None:
    path = _write(
        folder,
        "Strings2",
        "inputs:\n  greeting: {to: [a.textIn], value: hi}\n  name: {to: [a.label]}\n",
    )
    assert _validate(path) == (0, [])  # textIn is set from outside: no W030 either
    outcome = fmionnx.run(path, no_out=True, isolate="none", params={"name": "world!"})
    result = outcome.result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["a.textInLength"][-1] == len("hi")
    assert result.signals["a.labelLength"][-1] == len("world!")


def test_a_system_input_sets_a_binary_port_at_setup(folder: Path) -> None:
    path = _write(folder, "Binary3", 'inputs:\n  bytes: {to: [a.blob], value: "0c0d"}\n')
    assert _validate(path) == (0, [])
    result = fmionnx.run(path, no_out=True, isolate="none").result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["a.blobValue"][-1] == 0x0C0D


@pytest.mark.parametrize(
    ("fmu", "target", "dtype"),
    [("Strings2", "a.textIn", "string"), ("Binary3", "a.blob", "binary")],
)
def test_a_transformation_to_a_string_or_binary_port_is_refused_at_the_target(
    folder: Path, fmu: str, target: str, dtype: str
) -> None:
    path = _write(folder, fmu, f"inputs:\n  level: {{to: [{{to: {target}, factor: 2}}]}}\n")
    code, found = _validate(path)
    assert code == 1
    assert [f[:4] for f in found] == [("error", "E031", 7, 16)]  # no W030 besides
    assert (
        f"system input `level` reaches `{target}`, a {dtype} port, through a linear "
        f"transformation (factor 2, offset 0)"
    ) in found[0][4]


def test_a_binary_value_that_is_not_hexadecimal_is_refused_at_the_value(folder: Path) -> None:
    path = _write(folder, "Binary3", 'inputs:\n  bytes: {to: [a.blob], value: "0c0"}\n')
    code, found = _validate(path)
    assert code == 1
    assert [f[:4] for f in found] == [("error", "E043", 7, 32)]
    assert "system input `bytes` (at `a.blob`)" in found[0][4]
    assert "hexadecimal text of whole bytes, got `0c0`" in found[0][4]


# -- images in record: ---------------------------------------------------------------------------


def _image_model(path: Path) -> Path:
    """``m`` = mean of an RGB image ``uint8[1,24,32,3]``; ``copy`` = the image itself."""
    graph = helper.make_graph(
        [
            helper.make_node("Cast", ["image"], ["f"], to=TensorProto.FLOAT),
            helper.make_node("ReduceMean", ["f"], ["m"], keepdims=0),
            helper.make_node("Identity", ["image"], ["copy"]),
        ],
        "mean",
        [helper.make_tensor_value_info("image", TensorProto.UINT8, [1, 24, 32, 3])],
        [
            helper.make_tensor_value_info("m", TensorProto.FLOAT, []),
            helper.make_tensor_value_info("copy", TensorProto.UINT8, [1, 24, 32, 3]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


def _camera_system(folder: Path, record: str) -> Path:
    model = _image_model(folder / "mean.onnx")
    scene = FIXTURES / "scenes" / "rover.xml"
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: camera\nrun: {stop: 0.02, step: 0.01}\ncomponents:\n"
        f"  world: {{kind: mujoco, path: {scene}, cameras: {{front: {{width: 32, height: 24}}}}}}\n"
        f"  det: {{kind: onnx, path: {model}}}\n"
        f"connections:\n  - world.front -> det.image\nrecord: {record}\n",
        encoding="utf-8",
    )
    return path


@pytest.mark.parametrize(
    ("entry", "what"),
    [
        ("world.front", "an image port (uint8[24,32,3])"),  # a camera
        ("det.copy", "an image port (uint8[1,24,32,3])"),  # an ONNX output
        ("det.image", "an image port (uint8[1,24,32,3])"),  # an ONNX input
        ('"world.front[0,0,0]"', "an element of an image port (uint8[24,32,3])"),
    ],
)
def test_a_record_entry_naming_an_image_is_refused_at_the_entry(
    folder: Path, entry: str, what: str
) -> None:
    path = _camera_system(folder, f"[det.m, {entry}]")
    code, found = _validate(path)
    assert code == 1
    errors = [f for f in found if f[0] == "error"]
    assert [f[1:4] for f in errors] == [("E025", 9, 17)]
    assert f"is {what}: images are not recorded in results" in errors[0][4]


def test_the_hint_says_where_frames_and_numbers_go(folder: Path) -> None:
    path = _camera_system(folder, "[world.front]")
    result = CliRunner().invoke(app, ["validate", path.name])
    assert result.exit_code == 1
    assert "results keep numeric scalar and array ports" in result.output
    assert "--record FILE.mcap" in result.output
