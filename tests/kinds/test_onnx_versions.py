"""``fmionnx validate MODEL.onnx`` refuses what the installed onnxruntime cannot load.

The ONNX checker and shape inference passed a model stamped with an opset onnxruntime does
not implement, or using an operator of a domain it has no kernel for; ``run`` then refused it.
The lone model's check now loads it into an onnxruntime session (nothing is run) and reports
onnxruntime's reason as E019.
"""

from __future__ import annotations

from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper

from tests.conftest import cli


def _model(
    folder: Path,
    name: str,
    *,
    imports: dict[str, int],
    op: tuple[str, str] = ("", "Relu"),
    functions: list[onnx.FunctionProto] | None = None,
) -> Path:
    """A one-node model ``y = op(x)`` importing the opsets ``imports`` (domain -> version)."""
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [2])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [2])
    node = helper.make_node(op[1], ["x"], ["y"], domain=op[0])
    graph = helper.make_graph([node], "g", [x], [y])
    opsets = [helper.make_opsetid(domain, version) for domain, version in imports.items()]
    model = helper.make_model(graph, opset_imports=opsets, functions=functions or [])
    model.ir_version = 8
    path = folder / f"{name}.onnx"
    onnx.save(model, path)
    return path


@pytest.mark.parametrize(
    ("imports", "op", "said"),
    [
        ({"": 99}, ("", "Relu"), "Opset 99"),
        ({"": 17, "ai.onnx.ml": 99}, ("", "Relu"), "Opset 99"),
        ({"": 17, "my.custom": 1}, ("my.custom", "Foo"), "my.custom:Foo"),
    ],
)
def test_a_model_onnxruntime_cannot_load_is_e019(
    tmp_path: Path, imports: dict[str, int], op: tuple[str, str], said: str
) -> None:
    path = _model(tmp_path, "m", imports=imports, op=op)
    code, out = cli("validate", str(path))
    assert code == 1, out
    assert "error[E019" in out
    assert "onnxruntime" in out
    assert "cannot load the model" in out
    assert said in out
    assert "ONNXRuntimeError" not in out
    assert ".cc:" not in out


def test_a_model_onnxruntime_loads_passes(tmp_path: Path) -> None:
    code, out = cli("validate", str(_model(tmp_path, "ok", imports={"": 17})))
    assert code == 0, out


def test_a_custom_domain_the_model_defines_as_a_function_passes(tmp_path: Path) -> None:
    """A custom domain is no fault in itself: onnxruntime inlines the model's own functions."""
    body = helper.make_node("Relu", ["a"], ["b"])
    function = helper.make_function(
        "my.custom", "Foo", ["a"], ["b"], [body], [helper.make_opsetid("", 17)]
    )
    path = _model(
        tmp_path, "fn", imports={"": 17, "my.custom": 1}, op=("my.custom", "Foo"),
        functions=[function],
    )  # fmt: skip
    code, out = cli("validate", str(path))
    assert code == 0, out
