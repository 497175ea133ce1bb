"""A scene's map through the kind: fixed sites, visible static shapes in their colours."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fmionnx.kinds.base import MAP, MapSource, SceneMap
from fmionnx.kinds.mujoco import scenemap
from fmionnx.kinds.mujoco.scenemap import convex_hull
from fmionnx.kinds.registry import COMPONENT_KINDS
from tests.conftest import REPO

SCENE = """\
<mujoco>
  <asset><material name="teal" rgba="0 0.5 0.5 1"/></asset>
  <worldbody>
    <geom name="ground" type="plane" size="5 5 0.1"/>
    <site name="goal" pos="1 2 0" rgba="1 0 0 1"/>
    <geom name="crate" type="box" pos="2 0 0.5" size="0.5 0.25 0.5" rgba="0 0 1 1"/>
    <body name="turned" pos="0 3 0" euler="0 0 45">
      <geom name="plank" type="box" size="1 0.1 0.2" material="teal"/>
    </body>
    <geom name="pillar" type="cylinder" pos="-2 0 1" size="0.3 1"/>
    <geom name="ball" type="sphere" pos="-3 -3 0.5" size="0.5"/>
    <geom name="hidden" type="box" pos="4 4 0" size="0.1 0.1 0.1" group="3"/>
    <geom name="glass" type="box" pos="4 -4 0" size="0.1 0.1 0.1" rgba="1 1 1 0"/>
    <body name="robot" pos="0 0 0.1">
      <freejoint/>
      <geom name="chassis" type="box" size="0.2 0.1 0.05"/>
      <site name="nose" pos="0.2 0 0"/>
    </body>
  </worldbody>
</mujoco>
"""


def _kind() -> MapSource:
    kinds = [k for k in COMPONENT_KINDS.values() if MAP in k.capabilities]
    assert len(kinds) == 1  # the simulator kind, found through the table
    kind = kinds[0]
    assert isinstance(kind, MapSource)
    return kind


@pytest.fixture
def scene_map(tmp_path: Path) -> SceneMap:
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE, encoding="utf-8")
    return _kind().scene_map(scene)


def test_only_fixed_sites_are_on_the_map(scene_map: SceneMap) -> None:
    assert [(s.name, s.x, s.y, s.rgba) for s in scene_map.sites] == [
        ("goal", 1.0, 2.0, (1.0, 0.0, 0.0, 1.0))
    ]


def test_visible_static_shapes_only_lowest_first(scene_map: SceneMap) -> None:
    """No ground plane, no hidden group, no transparent geom, nothing on a moving body."""
    assert [s.name for s in scene_map.shapes] == ["plank", "crate", "ball", "pillar"]
    assert [s.top for s in scene_map.shapes] == [0.2, 1.0, 1.0, 2.0]


def test_a_box_outline_is_its_rotated_footprint(scene_map: SceneMap) -> None:
    shapes = {s.name: s for s in scene_map.shapes}
    assert shapes["crate"].outline == ((1.5, -0.25), (2.5, -0.25), (2.5, 0.25), (1.5, 0.25))
    plank = shapes["plank"].outline
    assert len(plank) == 4
    half = math.sqrt(0.5)  # turned by 45 degrees: the long side runs along x = y
    assert max(x for x, _ in plank) == pytest.approx(half * 1.0 + half * 0.1, abs=1e-6)
    assert max(y for _, y in plank) == pytest.approx(3 + half * 1.1, abs=1e-6)


def test_round_shapes_are_circles_of_their_radius(scene_map: SceneMap) -> None:
    shapes = {s.name: s for s in scene_map.shapes}
    for name, centre, radius in (("pillar", (-2, 0), 0.3), ("ball", (-3, -3), 0.5)):
        distances = [math.dist(point, centre) for point in shapes[name].outline]
        assert distances == pytest.approx([radius] * len(distances), abs=1e-6)


def test_colours_are_the_geoms_own_else_their_materials(scene_map: SceneMap) -> None:
    shapes = {s.name: s for s in scene_map.shapes}
    assert shapes["crate"].rgba == (0.0, 0.0, 1.0, 1.0)
    assert shapes["plank"].rgba == (0.0, 0.5, 0.5, 1.0)
    assert shapes["pillar"].rgba == (0.5, 0.5, 0.5, 1.0)  # MuJoCo's default grey


def test_the_sign_course_map_has_a_and_b_and_three_coloured_boards() -> None:
    scene_map = _kind().scene_map(REPO / "models" / "world" / "sign_course.xml")
    assert [(s.name, s.x, s.y) for s in scene_map.sites] == [("A", 0.0, 0.0), ("B", 6.0, 3.0)]
    boards = {s.name: s for s in scene_map.shapes if s.name.endswith("_board")}
    colours = {name: shape.rgba[:3] for name, shape in boards.items()}
    assert colours == {
        "sign_left_board": (0.05, 0.05, 0.85),  # blue: turn left
        "sign_right_board": (0.05, 0.75, 0.05),  # green: turn right
        "sign_stop_board": (0.85, 0.05, 0.05),  # red: stop
    }
    assert boards["sign_stop_board"].outline == ((7.78, 2.7), (7.82, 2.7), (7.82, 3.3), (7.78, 3.3))
    assert not [s for s in scene_map.shapes if s.name in ("floor", "chassis", "wheel_left")]


def test_convex_hull_drops_inner_and_collinear_points() -> None:
    square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    assert convex_hull([*square, (0.5, 0.5), (0.5, 0.0), (0.0, 0.0)]) == square
    assert convex_hull([(0.0, 0.0), (1.0, 1.0)]) == [(0.0, 0.0), (1.0, 1.0)]


def test_a_map_keeps_the_largest_shapes_when_a_scene_has_too_many(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(scenemap, "MAX_SHAPES", 2)
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE, encoding="utf-8")
    kept = _kind().scene_map(scene).shapes
    # ball 0.79 m2 and crate 0.5 m2 stay; plank 0.4 m2 and pillar 0.28 m2 go
    assert [s.name for s in kept] == ["crate", "ball"]
    assert scenemap.area(((0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0))) == 2.0
