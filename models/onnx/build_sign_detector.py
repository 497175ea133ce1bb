"""Write the traffic-sign detector ONNX model (``sign_detector.onnx``), deterministically.

The model reproduces the colour-blob measure of the original Simulink example as a small
convolutional network, so that its outputs can be checked exactly against plain numpy:

* a pixel is of colour c when its RGB lies in c's box (red R>=100, G<=55, B<=50; green R<=50,
  G>=50, B<=50; blue R<=40, G<=55, B>=50; every bound inclusive);
* ``blobX[c]`` is the mean (0-based) column of c's pixels, -1 when there are none;
* ``blobSize[c]`` is ``sqrt(2 * count)``, 0 when there are none.

Network: Reshape the uint8 frame into 16 tiles of 30 rows (a free view) -> Scan over the tiles
of the convolutional network [Transpose the tile's bytes to NCHW -> Cast(uint8 -> float) ->
Conv 1x1 (one output channel per distinct box bound) -> Clip[0, 1] -> Conv 1x1 (sum of a
colour's bound indicators minus (n-1)) -> Relu -> colour masks (0/1) [1,3,30,640] -> ReduceSum
over the tile's rows] -> ReduceSum over tiles -> Cast to double -> MatMul with [1, column] ->
count and column sum -> Div/Where/Sqrt -> Cast to float.

Why it is fast (issue 14): the network runs tile by tile, so its float activations (7 channels,
540 KB per tile instead of 8.6 MB per frame) stay in a core's cache instead of going through
memory; the frame is read once, as uint8, and its only transposition is of a tile's bytes in
cache (the first version transposed the whole float frame), after which the first layer is a
plain 1x1 convolution (a 1x3 kernel with stride 3 on the channels-last rows avoided the
transposition but made onnxruntime build an im2col buffer, ~15 % slower); bounds shared by two
colours (G<=55 of red and blue, B<=50 of red and green) are one channel, so the first layer has
7 channels instead of 9; onnxruntime fuses each Conv with its activation (Clip, Relu). A 1x1
network is per pixel, so tiling by rows changes no value. The model is meant for onnxruntime's
``ORT_ENABLE_EXTENDED`` level: ``ORT_ENABLE_ALL`` rewrites the convolutions to the blocked
NCHWc layout, whose reorders cost several times the whole model here.

Why it is exact: inputs are integers, so each bound pre-activation is an odd integer (..., -1, 1,
...) and Clip maps it to exactly 0 or 1; the second Conv sums at most three 0/1 values, so Relu
of (sum - (n-1)) is exactly 1 when all bounds hold and 0 otherwise. Per-column counts (<= 480)
are exact in float32; the column-weighted sum can exceed 2**24, so it is taken in float64.

Run as a script: ``python build_sign_detector.py OUT.onnx``; ``models/build.py`` calls
:func:`write_model`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

HEIGHT, WIDTH = 480, 640
#: Rows per tile: the activations of one tile (7 float channels, 540 KB) stay in a core's cache.
TILE_ROWS = 30
OPSET = 17

#: Colour boxes in the output order (index 0 red = stop, 1 green = right, 2 blue = left):
#: per channel R, G, B an inclusive (low, high) range of 8-bit values.
BOXES: dict[str, tuple[tuple[int, int], tuple[int, int], tuple[int, int]]] = {
    "red": ((100, 255), (0, 55), (0, 50)),
    "green": ((0, 50), (50, 255), (0, 50)),
    "blue": ((0, 40), (0, 55), (50, 255)),
}


def distinct_bounds() -> tuple[list[tuple[int, int, int]], list[list[int]]]:
    """The bounds that can fail for an 8-bit value, each once, and which colour uses which.

    Returns (bounds, members): ``bounds[k] = (channel, sign, threshold)`` holds where
    ``sign * (x[channel] - threshold) >= 0`` (sign +1 a low bound, -1 a high bound; a low bound
    of 0 or a high bound of 255 always holds and is left out); ``members[c]`` lists the bound
    indices of colour ``c``. A bound shared by two colours is one channel.
    """
    bounds: list[tuple[int, int, int]] = []
    members: list[list[int]] = []
    for box in BOXES.values():
        mine: list[int] = []
        for channel, (low, high) in enumerate(box):
            wanted = [(channel, 1, low)] if low > 0 else []
            wanted += [(channel, -1, high)] if high < 255 else []
            for bound in wanted:
                if bound not in bounds:
                    bounds.append(bound)
                mine.append(bounds.index(bound))
        members.append(mine)
    return bounds, members


def bound_layers() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weights and biases of both convolutions, derived from :data:`BOXES`.

    Returns (w1 [K,3,1,1], b1 [K], w2 [3,K,1,1], b2 [3]) for the K distinct bounds. Layer 1
    gives ``2*sign*(x - threshold) + 1``: an odd integer, >= 1 where the bound holds and <= -1
    where it fails.
    """
    bounds, members = distinct_bounds()
    count = len(bounds)
    w1 = np.zeros((count, 3, 1, 1), np.float32)
    b1 = np.zeros(count, np.float32)
    for k, (channel, sign, threshold) in enumerate(bounds):
        w1[k, channel, 0, 0] = 2.0 * sign
        b1[k] = -2.0 * sign * threshold + 1.0
    w2 = np.zeros((3, count, 1, 1), np.float32)
    b2 = np.zeros(3, np.float32)
    for colour, mine in enumerate(members):
        w2[colour, mine, 0, 0] = 1.0
        b2[colour] = -(len(mine) - 1.0)
    return w1, b1, w2, b2


def tile_network() -> onnx.GraphProto:
    """The convolutional network on one tile of ``TILE_ROWS`` rows: its masks' column counts.

    Input ``tile`` uint8 [1, TILE_ROWS, WIDTH, 3] (rows of the camera's channels-last frame);
    output ``tile_count`` float [1, 3, WIDTH], the pixels of each colour per column of the tile.
    """
    w1, b1, w2, b2 = bound_layers()
    initializers = [
        numpy_helper.from_array(w1, "bound_weight"),
        numpy_helper.from_array(b1, "bound_bias"),
        numpy_helper.from_array(w2, "colour_weight"),
        numpy_helper.from_array(b2, "colour_bias"),
        numpy_helper.from_array(np.array(0.0, np.float32), "zero"),
        numpy_helper.from_array(np.array(1.0, np.float32), "one"),
        numpy_helper.from_array(np.array([2], np.int64), "row_axis"),
    ]
    node = helper.make_node
    nodes = [
        node(
            "Transpose",
            ["tile"],
            ["tile_nchw"],
            perm=[0, 3, 1, 2],
            name="to_nchw",
            doc_string="The tile's channels-last bytes to NCHW (uint8, in cache): the first "
            "layer is then a plain 1x1 convolution, one matrix product without im2col.",
        ),
        node(
            "Cast",
            ["tile_nchw"],
            ["tile_f"],
            to=TensorProto.FLOAT,
            name="to_float",
            doc_string="8-bit RGB to float32 (exact).",
        ),
        node(
            "Conv",
            ["tile_f", "bound_weight", "bound_bias"],
            ["bound_pre"],
            kernel_shape=[1, 1],
            name="bounds",
            doc_string="One channel per distinct colour-box bound: >= 1 where it holds, "
            "<= -1 where it fails.",
        ),
        node(
            "Clip",
            ["bound_pre", "zero", "one"],
            ["bound_ok"],
            name="bound_step",
            doc_string="Step activation: 1 where the bound holds, else 0.",
        ),
        node(
            "Conv",
            ["bound_ok", "colour_weight", "colour_bias"],
            ["colour_pre"],
            kernel_shape=[1, 1],
            name="colours",
            doc_string="Per colour: (number of bounds holding) - (number of bounds - 1).",
        ),
        node(
            "Relu",
            ["colour_pre"],
            ["mask"],
            name="all_bounds",
            doc_string="Colour mask: 1 where every bound of the box holds, else 0.",
        ),
        node(
            "ReduceSum",
            ["mask", "row_axis"],
            ["tile_count"],
            keepdims=0,
            name="count_rows",
            doc_string="Pixels per colour and column of the tile (exact).",
        ),
    ]
    tile = helper.make_tensor_value_info("tile", TensorProto.UINT8, [1, TILE_ROWS, WIDTH, 3])
    tile.doc_string = f"{TILE_ROWS} rows of the frame, RGB, channels last."
    count = helper.make_tensor_value_info("tile_count", TensorProto.FLOAT, [1, 3, WIDTH])
    count.doc_string = "Pixels of red, green, blue per column of the tile."
    return helper.make_graph(
        nodes,
        "colour_masks_per_tile",
        [tile],
        [count],
        initializer=initializers,
        doc_string="The convolutional network on one tile: colour masks, counted per column.",
    )


def make_model() -> onnx.ModelProto:
    """Build the detector graph (see the module docstring for its layers)."""
    columns = np.stack([np.ones(WIDTH), np.arange(WIDTH, dtype=np.float64)], axis=1)
    tiles, rest = divmod(HEIGHT, TILE_ROWS)
    assert rest == 0, "tiles cover the frame"
    initializers = [
        numpy_helper.from_array(np.array([tiles, 1, TILE_ROWS, WIDTH, 3], np.int64), "tile_shape"),
        numpy_helper.from_array(np.array([0], np.int64), "tile_axis"),
        numpy_helper.from_array(columns, "count_and_column"),
        numpy_helper.from_array(np.array([1, 1], np.int64), "split_sizes"),
        numpy_helper.from_array(np.array([1, 3], np.int64), "out_shape"),
        numpy_helper.from_array(np.array(0.0, np.float64), "zero_d"),
        numpy_helper.from_array(np.array(1.0, np.float64), "one_d"),
        numpy_helper.from_array(np.array(2.0, np.float64), "two_d"),
        numpy_helper.from_array(np.array(-1.0, np.float64), "absent_x"),
    ]
    node = helper.make_node
    nodes = [
        node(
            "Reshape",
            ["image", "tile_shape"],
            ["tiles"],
            name="tiles",
            doc_string=f"[1,{HEIGHT},{WIDTH},3] -> [{tiles},1,{TILE_ROWS},{WIDTH},3]: "
            f"{tiles} tiles of {TILE_ROWS} rows (no copy).",
        ),
        node(
            "Scan",
            ["tiles"],
            ["tile_counts"],
            body=tile_network(),
            num_scan_inputs=1,
            name="per_tile",
            doc_string="The network on each tile in turn, so that its intermediate "
            "activations stay in the CPU cache.",
        ),
        node(
            "ReduceSum",
            ["tile_counts", "tile_axis"],
            ["column_count"],
            keepdims=0,
            name="count_tiles",
            doc_string="Pixels per colour and column of the frame [1,3,640] (exact).",
        ),
        node(
            "Cast",
            ["column_count"],
            ["column_count_d"],
            to=TensorProto.DOUBLE,
            name="to_double",
            doc_string="Column sums reach 2e8: float64 keeps them exact.",
        ),
        node(
            "MatMul",
            ["column_count_d", "count_and_column"],
            ["moments"],
            name="moments",
            doc_string="Per colour: pixel count and column-weighted count [1,3,2].",
        ),
        node(
            "Split",
            ["moments", "split_sizes"],
            ["count3", "column_sum3"],
            axis=2,
            name="split_moments",
        ),
        node("Reshape", ["count3", "out_shape"], ["count"], name="count_2d"),
        node("Reshape", ["column_sum3", "out_shape"], ["column_sum"], name="column_sum_2d"),
        node("Greater", ["count", "zero_d"], ["seen"], name="seen"),
        node(
            "Max",
            ["count", "one_d"],
            ["safe_count"],
            name="safe_count",
            doc_string="Avoids 0/0 where a colour is absent (masked by Where).",
        ),
        node("Div", ["column_sum", "safe_count"], ["mean_column"], name="mean_column"),
        node("Where", ["seen", "mean_column", "absent_x"], ["blob_x_d"], name="absent_is_minus1"),
        node("Mul", ["count", "two_d"], ["twice_count"], name="twice_count"),
        node("Sqrt", ["twice_count"], ["blob_size_d"], name="blob_size"),
        node("Cast", ["blob_x_d"], ["blobX"], to=TensorProto.FLOAT, name="blobX_float"),
        node("Cast", ["blob_size_d"], ["blobSize"], to=TensorProto.FLOAT, name="blobSize_float"),
    ]
    image = helper.make_tensor_value_info("image", TensorProto.UINT8, [1, HEIGHT, WIDTH, 3])
    image.doc_string = "Camera frame, RGB, row 0 at the top, 8 bits per channel."
    blob_x = helper.make_tensor_value_info("blobX", TensorProto.FLOAT, [1, 3])
    blob_x.doc_string = "Mean 0-based column of red, green, blue pixels; -1 when none."
    blob_size = helper.make_tensor_value_info("blobSize", TensorProto.FLOAT, [1, 3])
    blob_size.doc_string = "sqrt(2 * pixel count) of red, green, blue; 0 when none."
    graph = helper.make_graph(
        nodes,
        "sign_detector",
        [image],
        [blob_x, blob_size],
        initializer=initializers,
        doc_string="Colour-box traffic-sign detector (red = stop, green = right, blue = left).",
    )
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="fmionnx models/onnx/build_sign_detector.py",
        producer_version="2.2",
        model_version=4,
        doc_string=__doc__.split("\n\n")[0] if __doc__ else "",
    )
    model.ir_version = 8  # readable by onnxruntime releases of the last years
    helper.set_model_props(
        model,
        {
            "classes": "red,green,blue",
            "actions": "stop,turn_right,turn_left",
            "boxes": ";".join(f"{name}:{box}" for name, box in BOXES.items()),
            "blobX": "mean 0-based column, -1 when absent",
            "blobSize": "sqrt(2*count), 0 when absent",
        },
    )
    onnx.checker.check_model(model, full_check=True)
    return onnx.shape_inference.infer_shapes(model, check_type=True, strict_mode=True)


def write_model(path: Path) -> Path:
    """Write the model to ``path`` (byte-identical on every run) and return it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(make_model().SerializeToString(deterministic=True))
    tmp.replace(path)
    return path


if __name__ == "__main__":
    write_model(Path(sys.argv[1] if len(sys.argv) > 1 else "sign_detector.onnx"))
