"""The MuJoCo sign course: its interface, its drive, headless rendering, and the full loop."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
import mujoco  # after choosing the headless GL backend

from tests.conftest import REPO

SCENE = REPO / "models" / "world" / "sign_course.xml"


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(SCENE))


def test_scene_exposes_the_documented_interface(model):
    camera = model.camera("front")
    assert model.cam_resolution[camera.id].tolist() == [640, 480]
    assert camera.fovy[0] == 45
    assert model.sensor("base_pos").dim[0] == 3
    assert model.sensor("base_pos").type[0] == mujoco.mjtSensor.mjSENS_FRAMEPOS
    assert model.sensor("base_quat").dim[0] == 4
    assert model.sensor("base_quat").type[0] == mujoco.mjtSensor.mjSENS_FRAMEQUAT
    assert {model.actuator(i).name for i in range(model.nu)} == {"cmd_v", "cmd_w"}


def test_start_and_goal_sites_are_the_ends_of_the_expected_path(model):
    path = np.loadtxt(SCENE.with_suffix(".path.csv"), delimiter=",", skiprows=1, ndmin=2)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.site("A").xpos[:2], path[0])
    np.testing.assert_allclose(data.site("B").xpos[:2], path[-1])
    assert len(path) >= 4  # A, two corners, B


@pytest.mark.parametrize(("v", "w"), [(0.5, 0.0), (0.0, 0.8), (0.3, -0.5)])
def test_velocity_actuators_track_the_commanded_body_speeds(model, v, w):
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("cmd_v").id] = v
    data.ctrl[model.actuator("cmd_w").id] = w
    mujoco.mj_step(model, data, nstep=750)  # 1.5 s: well past the servo transient
    heading = 2 * np.arctan2(data.qpos[6], data.qpos[3])
    forward = data.qvel[0] * np.cos(heading) + data.qvel[1] * np.sin(heading)
    lateral = -data.qvel[0] * np.sin(heading) + data.qvel[1] * np.cos(heading)
    assert forward == pytest.approx(v, abs=0.03)
    assert data.qvel[5] == pytest.approx(w, abs=0.05 * abs(w) + 0.01)
    assert abs(lateral) < 0.01  # the wheels do not skid sideways


def test_front_camera_renders_offscreen_and_sees_the_blue_sign_from_a(model):
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, 480, 640) as renderer:
        renderer.update_scene(data, "front")
        image = renderer.render()
    assert image.shape == (480, 640, 3)
    blue = (image[..., 2] >= 50) & (image[..., 0] <= 40) & (image[..., 1] <= 55)
    assert blue.sum() > 2000
    assert abs(np.nonzero(blue)[1].mean() - 319.5) < 5  # straight ahead


def test_handwritten_loop_drives_from_a_to_b_taking_every_turn(handwritten_loop):
    result = handwritten_loop.run(32.0)
    summary = handwritten_loop.summary(result)
    assert summary["goal_distance"] < 0.5
    assert summary["max_path_deviation"] < 0.3
    assert summary["left_turns"] == 1
    assert summary["right_turns"] == 1
    assert result["stopRobot"][-1] == 1.0
    assert summary["stop_time"] < 32.0
