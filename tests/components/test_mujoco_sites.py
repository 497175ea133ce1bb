"""A scene's sites through the kind: fixed ones are landmarks, carried ones name their body."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.kinds.base import SITES, Site, SiteSource
from fmionnx.kinds.registry import COMPONENT_KINDS
from tests.conftest import REPO

SCENE = """\
<mujoco>
  <worldbody>
    <site name="fixed" pos="1 2 3"/>
    <body name="post" pos="5 0 0">
      <site name="on_post" pos="0 0 1"/>
      <body name="arm" pos="0 0 1">
        <joint type="hinge" axis="0 0 1"/>
        <geom size="0.1"/>
        <site name="on_arm" pos="1 0 0"/>
      </body>
    </body>
    <body name="target" mocap="true" pos="0 4 0">
      <site name="on_target"/>
    </body>
  </worldbody>
</mujoco>
"""


def _kind() -> SiteSource:
    kinds = [k for k in COMPONENT_KINDS.values() if SITES in k.capabilities]
    assert len(kinds) == 1  # the simulator kind, found through the table
    kind = kinds[0]
    assert isinstance(kind, SiteSource)
    return kind


def test_fixed_sites_have_their_world_position_and_moving_ones_their_body(tmp_path: Path) -> None:
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE, encoding="utf-8")
    sites = _kind().sites(scene)
    assert sites["fixed"] == Site((1.0, 2.0, 3.0))
    assert sites["on_post"] == Site((5.0, 0.0, 1.0))  # welded to the world: fixed
    assert sites["on_arm"].moves_with == "arm"
    assert sites["on_arm"].position == pytest.approx((6.0, 0.0, 1.0))
    assert sites["on_target"].moves_with == "target"  # a mocap body moves without a joint


def test_the_sign_course_has_its_start_and_goal() -> None:
    sites = _kind().sites(REPO / "models" / "world" / "sign_course.xml")
    assert sites["A"] == Site((0.0, 0.0, 0.002))
    assert sites["B"] == Site((6.0, 3.0, 0.002))
    assert sites["base"].moves_with == "base"
