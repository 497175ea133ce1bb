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


# -- MuJoCo scenes --------------------------------------------------------------------------

#: Scenes of a few hundred bytes that ask MuJoCo for gigabytes or minutes, by name: what each
#: holds inside ``<mujoco>``.
SCENE_BOMBS = {
    "hfield": '<asset><hfield name="h" nrow="40000" ncol="40000" size="1 1 1 1"/></asset>'
    '<worldbody><geom type="hfield" hfield="h"/></worldbody>',
    "texture": '<asset><texture name="t" type="2d" builtin="checker" width="30000" '
    'height="30000"/></asset><worldbody><geom size="1"/></worldbody>',
    "cube-texture": '<asset><texture name="t" type="cube" builtin="flat" width="20000" '
    'height="20000"/></asset><worldbody><geom size="1"/></worldbody>',
    "png-texture": '<asset><texture name="t" type="2d" file="huge.png"/></asset>'
    '<worldbody><geom size="1"/></worldbody>',
    "replicate-1e9": '<worldbody><replicate count="1000000000" offset="0 0 1">'
    '<geom size="1"/></replicate></worldbody>',
    "replicate-1e6": '<worldbody><replicate count="1000000" offset="0 0 1">'
    '<geom size="1"/></replicate></worldbody>',
    "flexcomp-1500": '<worldbody><flexcomp name="f" type="grid" count="1500 1500 1" '
    'spacing="0.1 0.1 0.1" dim="2"/></worldbody>',
    "bodies-1e5": '<worldbody><replicate count="100" offset="1 0 0"><replicate count="1000" '
    'offset="0 1 0"><body><geom size="0.1"/></body></replicate></replicate></worldbody>',
    "include-in-replicate": '<worldbody><replicate count="5000" offset="0 0 1">'
    '<include file="part.xml"/></replicate></worldbody>',
    "size-memory": '<size memory="100G"/><worldbody><geom size="1"/></worldbody>',
    "nuserdata": '<size nuserdata="1000000000"/><worldbody><geom size="1"/></worldbody>',
}


def png_header(width: int, height: int) -> bytes:
    """The first bytes of a PNG that declares ``width`` x ``height`` (its data is missing: a
    decoder that believed the header would allocate before it found out)."""
    import struct
    import zlib

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + header
    return (
        b"\x89PNG\r\n\x1a\n"
        + struct.pack(">I", len(header))
        + chunk
        + struct.pack(">I", zlib.crc32(chunk))
    )


def scene(path: Path, content: str) -> Path:
    """A scene file holding ``content`` (with what the bombs above name beside it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'<mujoco model="{path.stem}">{content}</mujoco>', "utf-8")
    (path.parent / "part.xml").write_text(
        '<mujoco><body><joint/><geom size="0.1"/></body></mujoco>', "utf-8"
    )
    (path.parent / "huge.png").write_bytes(png_header(100_000, 100_000))
    return path


def bodies(count: int) -> str:
    """``count`` bodies with a hinge joint each, written out (no ``replicate``)."""
    return (
        "<worldbody>"
        + "".join(f'<body pos="{i} 0 0"><joint/><geom size="0.1"/></body>' for i in range(count))
        + "</worldbody>"
    )


# -- ONNX models ----------------------------------------------------------------------------


def external_initializer(path: Path, elements: int) -> Path:
    """``y = x + w[0:1]``, ``w`` an initializer of ``elements`` floats declared stored in
    ``w.bin`` beside the model (only 4 bytes of it are written: the declaration is the bomb)."""
    w = TensorProto(name="w", data_type=TensorProto.FLOAT, dims=[elements])
    w.data_location = TensorProto.EXTERNAL
    for key, value in (("location", "w.bin"), ("offset", "0"), ("length", str(4 * elements))):
        entry = w.external_data.add()
        entry.key, entry.value = key, value
    graph = helper.make_graph(
        [
            helper.make_node("Slice", ["w", "zero", "one"], ["w0"]),
            helper.make_node("Add", ["x", "w0"], ["y"]),
        ],
        "external",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
        initializer=[
            w,
            helper.make_tensor("zero", TensorProto.INT64, [1], [0]),
            helper.make_tensor("one", TensorProto.INT64, [1], [1]),
        ],
    )
    model = helper.make_model(graph, opset_imports=OPSET)
    (path.parent).mkdir(parents=True, exist_ok=True)
    (path.parent / "w.bin").write_bytes(b"\0" * 4)
    return _save(model, path)


def sparse_initializer(path: Path, dense: list[int]) -> Path:
    """``y = x + s``, ``s`` a sparse initializer of one value whose dense shape is ``dense``
    (onnxruntime makes it dense when it loads the model)."""
    values = helper.make_tensor("s_values", TensorProto.FLOAT, [1], [1.0])
    indices = helper.make_tensor("s_indices", TensorProto.INT64, [1], [0])
    sparse = helper.make_sparse_tensor(values, indices, dense)
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])],
        "sparse",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
        sparse_initializer=[sparse],
    )
    return _save(helper.make_model(graph, opset_imports=OPSET), path)


def initializers(path: Path, count: int, elements: int) -> Path:
    """``y = x`` and ``count`` unused initializers of ``elements`` zeros each."""
    stored = [
        helper.make_tensor(f"w{i}", TensorProto.FLOAT, [elements], [0.0] * elements)
        for i in range(count)
    ]
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])],
        "many",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
        initializer=stored,
    )
    return _save(helper.make_model(graph, opset_imports=OPSET), path)


def many_ports(path: Path, count: int, elements: int) -> Path:
    """``count`` inputs ``x<i>`` of ``[elements]`` floats, each passed to an output."""
    graph = helper.make_graph(
        [helper.make_node("Identity", [f"x{i}"], [f"y{i}"]) for i in range(count)],
        "ports",
        [
            helper.make_tensor_value_info(f"x{i}", TensorProto.FLOAT, [elements])
            for i in range(count)
        ],
        [
            helper.make_tensor_value_info(f"y{i}", TensorProto.FLOAT, [elements])
            for i in range(count)
        ],
    )
    return _save(helper.make_model(graph, opset_imports=OPSET), path)


def expand(path: Path, shape: list[int] | None) -> Path:
    """``y = Expand(x, shape)``: with ``shape`` a constant of the model (a bomb of about a
    hundred bytes), or None for a shape read from the input ``shape`` at run time."""
    import numpy as np
    from onnx import numpy_helper

    nodes = [helper.make_node("Expand", ["x", "shape"], ["y"])]
    inputs = [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])]
    if shape is None:
        inputs.append(helper.make_tensor_value_info("shape", TensorProto.INT64, [2]))
    else:
        constant = numpy_helper.from_array(np.array(shape, np.int64), "shape")
        nodes.insert(0, helper.make_node("Constant", [], ["shape"], value=constant))
    graph = helper.make_graph(
        nodes,
        "expand",
        inputs,
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["rows", "cols"])],
    )
    return _save(helper.make_model(graph, opset_imports=OPSET), path)


def high_rank(path: Path, rank: int) -> Path:
    """``y = Identity(x)`` with ``x`` and ``y`` of ``rank`` dimensions of 1: one element, more
    dimensions than a numpy array can have."""
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])],
        "rank",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1] * rank)],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1] * rank)],
    )
    return _save(helper.make_model(graph, opset_imports=OPSET), path)
