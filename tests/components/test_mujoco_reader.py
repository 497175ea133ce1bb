"""MuJoCo interface reader: sensors, actuators, sites, cameras, units, facts, errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Causality, DType
from fmionnx.kinds.mujoco.kind import MUJOCO_KIND
from fmionnx.kinds.mujoco.spec import CameraSpec, MujocoSpec


def _spec(**cameras: CameraSpec) -> MujocoSpec:
    return MujocoSpec(path="rover.xml", cameras=cameras)


def test_named_sensors_actuators_and_sites_become_ports(rover_scene: Path) -> None:
    ports = MUJOCO_KIND.read_interface(rover_scene, _spec()).ports
    assert [(p.name, p.causality, p.dtype, p.shape) for p in ports] == [
        ("cart_pos", Causality.OUTPUT, DType.FLOAT64, (3,)),
        ("cart_quat", Causality.OUTPUT, DType.FLOAT64, (4,)),
        ("cart_gyro", Causality.OUTPUT, DType.FLOAT64, (3,)),
        ("cart_vel", Causality.OUTPUT, DType.FLOAT64, (3,)),
        ("pole_angle", Causality.OUTPUT, DType.FLOAT64, ()),
        ("push", Causality.INPUT, DType.FLOAT64, ()),
        ("nose.pos", Causality.OUTPUT, DType.FLOAT64, (3,)),
    ]


def test_sensor_units_follow_sensor_and_joint_type(rover_scene: Path) -> None:
    interface = MUJOCO_KIND.read_interface(rover_scene, _spec())
    units = {p.name: p.unit for p in interface.ports}
    assert units == {
        "cart_pos": "m",
        "cart_quat": None,
        "cart_gyro": "rad/s",
        "cart_vel": "m/s",
        "pole_angle": "rad",
        "push": None,
        "nose.pos": "m",
    }


def test_actuator_starts_at_zero_and_describes_its_range(rover_scene: Path) -> None:
    push = MUJOCO_KIND.read_interface(rover_scene, _spec()).port("push")
    assert push is not None
    assert push.start == (0.0,)
    assert "ctrlrange [-2, 2]" in push.description


def test_outputs_have_no_direct_feedthrough(rover_scene: Path) -> None:
    interface = MUJOCO_KIND.read_interface(rover_scene, _spec(front=CameraSpec()))
    outputs = [p for p in interface.ports if p.causality is Causality.OUTPUT]
    assert outputs
    assert all(p.depends_on == () for p in outputs)


def test_spec_cameras_become_image_ports_of_their_size(rover_scene: Path) -> None:
    spec = _spec(front=CameraSpec(width=64, height=48))
    interface = MUJOCO_KIND.read_interface(rover_scene, spec)
    cameras = [p for p in interface.ports if p.dtype is DType.UINT8]
    assert [(p.name, p.shape) for p in cameras] == [("front", (48, 64, 3))]


def test_without_spec_every_named_camera_is_640x480(rover_scene: Path) -> None:
    interface = MUJOCO_KIND.read_interface(rover_scene, None)
    cameras = [(p.name, p.shape) for p in interface.ports if p.dtype is DType.UINT8]
    assert cameras == [("overview", (480, 640, 3)), ("front", (480, 640, 3))]


def test_facts(rover_scene: Path) -> None:
    facts = dict(MUJOCO_KIND.read_interface(rover_scene, None).facts)
    assert facts == {"timestep": "0.002", "nbody": "3", "ngeom": "3", "cameras": "overview,front"}


def test_unknown_camera_is_e018_with_suggestion(rover_scene: Path) -> None:
    with pytest.raises(ModelError, match="camera `frnt` is not in the scene") as info:
        MUJOCO_KIND.read_interface(rover_scene, _spec(frnt=CameraSpec()))
    assert info.value.code is codes.UNKNOWN_OPTION
    assert info.value.hint == "did you mean `front`?"


@pytest.mark.parametrize(
    "text",
    [
        "<mujoco>\n  <worldbody>\n    <geom type='sphere' size='0.1'/>\n</mujoco>\n",
        "<mujoco>\n  <worldbody>\n    <geom type='sphere' size='x'/>\n  </worldbody>\n</mujoco>\n",
    ],
    ids=["not-well-formed", "bad-attribute"],
)
def test_bad_xml_is_e012_naming_the_line(tmp_path: Path, text: str) -> None:
    scene = tmp_path / "bad.xml"
    scene.write_text(text)
    with pytest.raises(ModelError, match=r"not a valid MuJoCo scene: .*[Ll]ine\D*\d") as info:
        MUJOCO_KIND.read_interface(scene, None)
    assert info.value.code is codes.BAD_MODEL


def test_missing_scene_is_e010(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="does not exist") as info:
        MUJOCO_KIND.read_interface(tmp_path / "none.xml", None)
    assert info.value.code is codes.FILE_NOT_FOUND


def test_same_name_on_sensor_and_actuator_is_e013(tmp_path: Path) -> None:
    scene = tmp_path / "clash.xml"
    scene.write_text(
        "<mujoco><worldbody><body><joint name='j' type='hinge'/>"
        "<geom size='0.1'/></body></worldbody>"
        "<actuator><motor name='j_out' joint='j'/></actuator>"
        "<sensor><jointpos name='j_out' joint='j'/></sensor></mujoco>"
    )
    with pytest.raises(
        ModelError, match="`j_out` is used by a jointpos sensor and an actuator;"
    ) as info:
        MUJOCO_KIND.read_interface(scene, None)
    assert info.value.code is codes.UNSUPPORTED_MODEL


def test_content_hash_follows_included_files(tmp_path: Path) -> None:
    from fmionnx.kinds.mujoco.interface import read_mujoco_interface

    part = tmp_path / "part.xml"
    scene = tmp_path / "scene.xml"
    part.write_text(
        '<mujocoinclude><geom name="box" type="box" size="0.1 0.1 0.1"/></mujocoinclude>'
    )
    scene.write_text('<mujoco><worldbody><include file="part.xml"/></worldbody></mujoco>')
    first = read_mujoco_interface(scene, None).content_hash
    (tmp_path / "copy").mkdir()
    for file in (part, scene):
        (tmp_path / "copy" / file.name).write_text(file.read_text())
    assert read_mujoco_interface(tmp_path / "copy" / "scene.xml", None).content_hash == first
    (tmp_path / "copy" / "part.xml").write_text(
        part.read_text().replace("0.1 0.1 0.1", "0.2 0.1 0.1")
    )
    (tmp_path / "copy" / "scene.xml").touch()
    changed = read_mujoco_interface(tmp_path / "copy" / "scene.xml", None).content_hash
    assert changed != first
