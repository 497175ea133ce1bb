"""Generators of the small hostile models the resource and timeout tests feed fmionnx.

Each builds its file from scratch (``onnx.helper``, MJCF text): nothing is downloaded and
nothing is checked in but these few lines. The files are tiny; what they would cost a reader
without its protection is what the tests are about.
"""

from __future__ import annotations

from pathlib import Path

import onnx
from onnx import TensorProto, helper

OPSET = [helper.make_opsetid("", 17)]


def _save(model: onnx.ModelProto, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(model.SerializeToString())
    return path


def endless_loop(path: Path, *, above: float | None = None) -> Path:
    """``y = x`` through a ``Loop`` that never ends: always, or once ``x[0] > above``.

    ``x`` and ``y`` are ``double[1]`` (a signal can drive ``x``). The loop has no trip count,
    and its body hands the condition on unchanged, so a true condition holds for ever.
    """
    body = helper.make_graph(
        [
            helper.make_node("Identity", ["cond_in"], ["cond_out"]),
            helper.make_node("Identity", ["v_in"], ["v_out"]),
        ],
        "body",
        [
            helper.make_tensor_value_info("i", TensorProto.INT64, []),
            helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
            helper.make_tensor_value_info("v_in", TensorProto.DOUBLE, [1]),
        ],
        [
            helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
            helper.make_tensor_value_info("v_out", TensorProto.DOUBLE, [1]),
        ],
    )
    if above is None:
        condition = [
            helper.make_node(
                "Constant", [], ["cond"], value=helper.make_tensor("t", TensorProto.BOOL, [], [1])
            )
        ]
    else:
        threshold = helper.make_tensor("a", TensorProto.DOUBLE, [], [above])
        condition = [
            helper.make_node("Constant", [], ["above"], value=threshold),
            helper.make_node("ReduceMax", ["x"], ["top"], keepdims=0),
            helper.make_node("Greater", ["top", "above"], ["cond"]),
        ]
    graph = helper.make_graph(
        [*condition, helper.make_node("Loop", ["", "cond", "x"], ["y"], body=body)],
        "endless",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [1])],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, [1])],
    )
    model = helper.make_model(graph, opset_imports=OPSET)
    onnx.checker.check_model(model, full_check=True)
    return _save(model, path)
