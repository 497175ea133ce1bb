"""The sign course renders only what the camera needs (issue 14), and why that is safe."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from tests.conftest import REPO, built_model
from tests.models.conftest import load_script

SCENE = REPO / "models" / "world" / "sign_course.xml"


@pytest.fixture(scope="module")
def measure_rendering():
    return load_script(REPO / "models" / "measure_rendering.py")


def test_scene_turns_off_what_the_detector_does_not_need() -> None:
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    assert model.vis.quality.offsamples == 0  # no multisampling
    assert model.vis.quality.shadowsize == 0
    assert int(mujoco.mjtTexture.mjTEXTURE_SKYBOX) not in model.tex_type.tolist()
    assert model.ntex == 0  # no skybox, no floor texture
    assert model.nlight == 0
    assert model.vis.headlight.active  # the headlight is the only light
    assert not model.mat_reflectance.any()


def test_before_scene_has_the_settings_of_the_first_course(measure_rendering) -> None:
    model = mujoco.MjModel.from_xml_string(measure_rendering.before_scene())
    assert model.vis.quality.offsamples == 4
    assert int(mujoco.mjtTexture.mjTEXTURE_SKYBOX) in model.tex_type.tolist()
    assert model.nlight == 1
    assert model.mat_texid[model.material("floor").id].max() >= 0
    # every setting is an edit that changes the compiled scene
    for name, edit in measure_rendering.SETTINGS.items():
        assert measure_rendering.scene_text([edit]) != measure_rendering.scene_text(), name


def test_anti_aliasing_is_what_made_the_detector_miss_the_true_board_pixels(
    measure_rendering, measure_detector
) -> None:
    """The committed scene gives 0 px (tests/models/test_sign_detector.py); the same poses with
    4x multisampling blend board edges, and the detector's pixel count or mean column no longer
    equals the board's."""
    built_model("sign_detector.onnx")
    session = measure_detector.detector_session()
    poses = measure_detector.sample_poses(8, seed=7)
    scene = measure_rendering.scene_text([measure_rendering.anti_aliasing])
    differ = 0
    for frame in measure_detector.render_frames(poses, scene):
        blob_x, blob_size = session.run(None, {"image": frame.image[np.newaxis]})
        for colour, columns in enumerate(frame.board_columns):
            if columns.size:
                exact = blob_size[0, colour] == np.float32(np.sqrt(2.0 * columns.size))
                exact &= blob_x[0, colour] == np.float32(columns.mean())
                differ += int(not exact)
    assert differ > 0


def test_setting_costs_are_measured_with_the_detector_accuracy(measure_rendering) -> None:
    built_model("sign_detector.onnx")
    costs = measure_rendering.measure(2, seed=7, settings=["anti-aliasing 4x", "haze"], repeats=1)
    assert [c.setting for c in costs] == ["anti-aliasing 4x", "haze"]
    by_name = {c.setting: c for c in costs}
    assert by_name["anti-aliasing 4x"].changed_pixels > 0
    assert by_name["haze"].changed_pixels == 0  # no skybox: haze draws nothing
    for cost in costs:
        assert cost.on_ms > 0
        assert cost.off_ms > 0
        assert cost.accuracy_off["onnx_vs_numpy"] == 0.0
        assert cost.accuracy_on["onnx_vs_numpy"] == 0.0
