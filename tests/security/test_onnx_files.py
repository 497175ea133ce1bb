"""ONNX models: external tensor data stays beside the model; tensor shapes are bounded.

Models are built here with ``onnx.helper``; runs use onnxruntime.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from fmionnx.compile.single import compile_single_model
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.errors import ModelError
from fmionnx.core.runner import Wiring
from fmionnx.kinds.onnx.kind import ONNX_KIND
from fmionnx.kinds.registry import make_runner

WEIGHTS = np.array([1.0, 2.0, 3.0], dtype=np.float32)


def _external(tensor: onnx.TensorProto, location: str) -> onnx.TensorProto:
    """``tensor`` with its bytes moved out to ``location`` (the bytes are not written)."""
    tensor.ClearField("raw_data")
    tensor.ClearField("float_data")
    tensor.data_location = TensorProto.EXTERNAL
    for key, value in (("location", location), ("offset", "0"), ("length", "12")):
        entry = tensor.external_data.add()
        entry.key, entry.value = key, value
    return tensor


def _scale(location: str | None, *, in_constant: bool = False) -> onnx.ModelProto:
    """``y = x * w`` with ``w`` an initializer (or a Constant node), stored at ``location``."""
    w = numpy_helper.from_array(WEIGHTS, "w")
    if location is not None:
        w = _external(w, location)
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 3])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 3])
    nodes = [helper.make_node("Mul", ["x", "w"], ["y"])]
    initializers = [w]
    if in_constant:
        nodes.insert(0, helper.make_node("Constant", [], ["w"], value=w))
        initializers = []
    graph = helper.make_graph(nodes, "scale", [x], [y], initializer=initializers)
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])


def _save(model: onnx.ModelProto, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(model.SerializeToString())
    return path


@pytest.fixture
def secret(tmp_path: Path) -> Path:
    """A file outside the model's folder that holds exactly what the model expects."""
    path = tmp_path / "secret.bin"
    path.write_bytes(WEIGHTS.tobytes())
    return path


@pytest.mark.parametrize(
    ("location", "message"),
    [
        ("../secret.bin", r"outside the model's folder \(`..`\)"),
        ("ABSOLUTE", "not a path relative"),
    ],
    ids=["dotdot", "absolute"],
)
def test_external_data_outside_the_folder_is_e017(
    tmp_path: Path, secret: Path, location: str, message: str
) -> None:
    where = str(secret) if location == "ABSOLUTE" else location
    path = _save(_scale(where), tmp_path / "model" / "scale.onnx")
    with pytest.raises(ModelError, match=message) as info:
        ONNX_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert "tensor `w`" in str(info.value)


def test_external_data_in_a_node_attribute_is_checked_too(tmp_path: Path, secret: Path) -> None:
    path = _save(_scale("../secret.bin", in_constant=True), tmp_path / "model" / "scale.onnx")
    with pytest.raises(ModelError, match="outside the model's folder") as info:
        ONNX_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_external_data_through_a_link_out_of_the_folder_is_e017(
    tmp_path: Path, secret: Path
) -> None:
    folder = tmp_path / "model"
    path = _save(_scale("weights.bin"), folder / "scale.onnx")
    (folder / "weights.bin").symlink_to(secret)
    with pytest.raises(ModelError, match="a link to a file outside") as info:
        ONNX_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def _runner(path: Path):  # type: ignore[no-untyped-def]
    compiled = compile_single_model(path, DiagnosticBag(), step=0.1)
    assert compiled is not None
    component = compiled.components[0]
    return make_runner(component, Wiring(driven=frozenset(), sizes={}))


def test_external_data_beside_the_model_runs(tmp_path: Path) -> None:
    folder = tmp_path / "model"
    path = _save(_scale("weights.bin"), folder / "scale.onnx")
    (folder / "weights.bin").write_bytes(WEIGHTS.tobytes())
    runner = _runner(path)
    runner.instantiate()
    runner.setup(0.0, 1.0)
    runner.input_buffer("x")[:] = 2.0
    runner.step(0.0, 0.1)
    assert list(runner.output_buffer("y")) == [2.0, 4.0, 6.0]
    runner.terminate()


def test_a_model_changed_after_compiling_is_checked_before_onnxruntime_loads_it(
    tmp_path: Path, secret: Path
) -> None:
    folder = tmp_path / "model"
    path = _save(_scale("weights.bin"), folder / "scale.onnx")
    (folder / "weights.bin").write_bytes(WEIGHTS.tobytes())
    runner = _runner(path)
    _save(_scale("../secret.bin"), path)  # rewritten between compile and run
    with pytest.raises(ModelError, match="outside the model's folder") as info:
        runner.instantiate()
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_a_tensor_of_a_trillion_elements_is_e008(tmp_path: Path) -> None:
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1000, 1000, 1000, 1000])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [1000, 1000, 1000, 1000])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "huge", [x], [y])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    path = _save(model, tmp_path / "huge.onnx")
    with pytest.raises(ModelError, match=r"input `x` of shape \[1000, 1000, 1000, 1000\]") as info:
        ONNX_KIND.read_interface(path, None)
    assert info.value.code is codes.RESOURCE_LIMIT
    assert "FMIONNX_MAX_ARRAY_ELEMENTS" in (info.value.hint or "")
