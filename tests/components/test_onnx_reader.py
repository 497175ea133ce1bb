"""ONNX interface reader: ports from graph inputs/outputs, shapes, facts, errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Causality, DType
from fmionnx.kinds.onnx.kind import ONNX_KIND


def test_initializers_are_not_inputs(onnx_models: dict[str, Path]) -> None:
    interface = ONNX_KIND.read_interface(onnx_models["scale"], None)
    assert [(p.name, p.causality, p.dtype, p.shape) for p in interface.ports] == [
        ("x", Causality.INPUT, DType.FLOAT32, (1, 3)),
        ("y", Causality.OUTPUT, DType.FLOAT32, (1, 3)),
    ]
    y = interface.port("y")
    assert y is not None
    assert y.description == "x scaled element-wise"


def test_symbolic_and_unknown_dimensions_are_kept(onnx_models: dict[str, Path]) -> None:
    interface = ONNX_KIND.read_interface(onnx_models["dynamic"], None)
    shapes = {p.name: (p.dtype, p.shape) for p in interface.ports}
    assert shapes == {
        "image": (DType.UINT8, ("batch", "?", 640, 3)),
        "count": (DType.INT64, ()),
        "pixels": (DType.FLOAT64, ("batch", "?", 640, 3)),
        "same": (DType.INT64, ()),
    }


def test_every_output_depends_on_every_input(onnx_models: dict[str, Path]) -> None:
    interface = ONNX_KIND.read_interface(onnx_models["dynamic"], None)
    assert {p.name: p.depends_on for p in interface.ports} == {
        "image": None,
        "count": None,
        "pixels": ("image", "count"),
        "same": ("image", "count"),
    }


def test_facts_name_ir_opset_producer_and_metadata(onnx_models: dict[str, Path]) -> None:
    facts = dict(ONNX_KIND.read_interface(onnx_models["scale"], None).facts)
    assert facts["opset"] == "17"
    assert facts["producer"] == "fmionnx-tests 1"
    assert facts["docString"] == "Scales a vector"
    assert facts["metadata.author"] == "fmionnx"
    assert facts["metadata.task"] == "test"
    assert int(facts["irVersion"]) >= 8
    assert facts["signature"] == "input x: float32[1,3]; output y: float32[1,3]"


def test_non_tensor_input_is_unsupported_e013(onnx_models: dict[str, Path]) -> None:
    with pytest.raises(ModelError, match="`items` is not a tensor") as info:
        ONNX_KIND.read_interface(onnx_models["sequence_input"], None)
    assert info.value.code is codes.UNSUPPORTED_MODEL


def test_bad_protobuf_is_e012(tmp_path: Path) -> None:
    path = tmp_path / "broken.onnx"
    path.write_bytes(b"\x08\x07\x12\xff\xff\xff this is not protobuf")
    with pytest.raises(ModelError, match="not an ONNX model") as info:
        ONNX_KIND.read_interface(path, None)
    assert info.value.code is codes.BAD_MODEL


def test_missing_model_is_e010(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="does not exist") as info:
        ONNX_KIND.read_interface(tmp_path / "none.onnx", None)
    assert info.value.code is codes.FILE_NOT_FOUND


def test_directory_is_e011(tmp_path: Path) -> None:
    folder = tmp_path / "model.onnx"
    folder.mkdir()
    with pytest.raises(ModelError, match="directory") as info:
        ONNX_KIND.read_interface(folder, None)
    assert info.value.code is codes.NOT_A_FILE
