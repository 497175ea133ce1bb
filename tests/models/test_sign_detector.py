"""The sign detector ONNX model against a plain numpy implementation of the same measure."""

from __future__ import annotations

import numpy as np
import onnx
import pytest

from tests.conftest import built_model


@pytest.fixture(scope="module")
def session(measure_detector):
    return measure_detector.detector_session(built_model("sign_detector.onnx"))


def detect(session, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    blob_x, blob_size = session.run(None, {"image": image[np.newaxis]})
    return blob_x[0], blob_size[0]


def test_model_passes_the_full_checker_and_strict_shape_inference():
    model = onnx.load(str(built_model("sign_detector.onnx")))
    onnx.checker.check_model(model, full_check=True)
    inferred = onnx.shape_inference.infer_shapes(model, check_type=True, strict_mode=True)
    shapes = {
        v.name: [d.dim_value for d in v.type.tensor_type.shape.dim] for v in inferred.graph.output
    }
    assert shapes == {"blobX": [1, 3], "blobSize": [1, 3]}
    (image,) = model.graph.input
    assert image.type.tensor_type.elem_type == onnx.TensorProto.UINT8
    assert [d.dim_value for d in image.type.tensor_type.shape.dim] == [1, 480, 640, 3]
    (scan,) = [n for n in model.graph.node if n.op_type == "Scan"]
    tile = onnx.helper.get_attribute_value(scan.attribute[0])
    ops = [n.op_type for n in tile.node]
    assert {"Conv", "Relu", "ReduceSum"} <= set(ops)
    assert "MatMul" in {n.op_type for n in model.graph.node}
    # issue 14: the network runs tile by tile on the uint8 frame; the only transposition is of
    # a tile's bytes, none of the whole frame, none of floats
    assert [n.op_type for n in model.graph.node][:2] == ["Reshape", "Scan"]
    assert "Transpose" not in [n.op_type for n in model.graph.node]
    assert ops[:6] == ["Transpose", "Cast", "Conv", "Clip", "Conv", "Relu"]
    (tile_input,) = tile.input
    assert tile_input.type.tensor_type.elem_type == onnx.TensorProto.UINT8
    weights = {i.name: onnx.numpy_helper.to_array(i) for i in tile.initializer}
    assert weights["bound_weight"].shape == (7, 3, 1, 1)  # 7 distinct bounds, 1x1 over R,G,B
    assert all(v.doc_string for v in [*model.graph.input, *model.graph.output])
    props = {p.key: p.value for p in model.metadata_props}
    assert props["classes"] == "red,green,blue"


def test_builder_is_deterministic(detector_builder, tmp_path):
    first = detector_builder.write_model(tmp_path / "a.onnx").read_bytes()
    second = detector_builder.write_model(tmp_path / "b.onnx").read_bytes()
    assert first == second
    assert first == built_model("sign_detector.onnx").read_bytes()


def test_every_8bit_colour_is_classified_like_numpy(session, measure_detector):
    # all 2**24 colours, 54.6 frames' worth, each frame compared as a whole
    colours = np.arange(2**24, dtype=np.uint32)
    per_frame = 480 * 640
    for start in range(0, colours.size, per_frame):
        chunk = colours[start : start + per_frame]
        frame = np.zeros((per_frame, 3), np.uint8)
        frame[: chunk.size, 0] = chunk >> 16
        frame[: chunk.size, 1] = (chunk >> 8) & 0xFF
        frame[: chunk.size, 2] = chunk & 0xFF
        image = frame.reshape(480, 640, 3)
        blob_x, blob_size = detect(session, image)
        ref_x, ref_size = measure_detector.numpy_blobs(image)
        np.testing.assert_array_equal(blob_size, ref_size.astype(np.float32))
        np.testing.assert_array_equal(blob_x, ref_x.astype(np.float32))


def test_empty_image_reports_no_blob(session):
    blob_x, blob_size = detect(session, np.full((480, 640, 3), 128, np.uint8))
    assert blob_x.tolist() == [-1.0, -1.0, -1.0]
    assert blob_size.tolist() == [0.0, 0.0, 0.0]


def test_rectangles_give_their_centre_column_and_size(session):
    image = np.full((480, 640, 3), 200, np.uint8)
    image[100:200, 0:50] = (255, 0, 0)  # red: 5000 px, columns 0..49
    image[300:310, 600:640] = (0, 255, 0)  # green: 400 px, columns 600..639
    image[0:480, 320:321] = (0, 0, 255)  # blue: one full column
    blob_x, blob_size = detect(session, image)
    np.testing.assert_array_equal(blob_x, np.float32([24.5, 619.5, 320.0]))
    np.testing.assert_array_equal(blob_size, np.sqrt(np.float32([10000, 800, 960])))


def test_whole_image_of_one_colour_is_counted_exactly(session):
    image = np.zeros((480, 640, 3), np.uint8)
    image[..., 2] = 255
    blob_x, blob_size = detect(session, image)
    assert blob_x.tolist() == [-1.0, -1.0, 319.5]
    assert blob_size[2] == np.float32(np.sqrt(2 * 480 * 640))


def test_rendered_course_frames_match_numpy_and_the_true_board_pixels(session, measure_detector):
    """0 px: on frames rendered without anti-aliasing (the course's setting), the pixels the
    detector counts for a colour are exactly its board's pixels in MuJoCo's segmentation image,
    so blobX is the board's true mean column and blobSize its true size, for every board in
    view however small, and nothing is reported for a board out of view."""
    poses = measure_detector.sample_poses(16, seed=7)
    checked = 0
    for frame in measure_detector.render_frames(poses):
        blob_x, blob_size = detect(session, frame.image)
        ref_x, ref_size = measure_detector.numpy_blobs(frame.image)
        np.testing.assert_array_equal(blob_x, ref_x.astype(np.float32))
        np.testing.assert_array_equal(blob_size, ref_size.astype(np.float32))
        for colour, columns in enumerate(frame.board_columns):
            if columns.size == 0:
                assert blob_size[colour] == 0.0, frame.pose
                assert blob_x[colour] == -1.0, frame.pose
                continue
            assert blob_size[colour] == np.float32(np.sqrt(2.0 * columns.size)), frame.pose
            assert blob_x[colour] == np.float32(columns.mean()), frame.pose
            checked += int(columns.size >= measure_detector.MIN_PIXELS)
    assert checked >= 8  # the sample really shows signs
