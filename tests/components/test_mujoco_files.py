"""A MuJoCo scene cannot make fmionnx (or MuJoCo) read a file outside the scene's folder."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.kinds.mujoco.files import check_scene_files
from fmionnx.kinds.mujoco.interface import read_mujoco_interface

BOX = '<mujocoinclude><geom name="box" type="box" size="0.1 0.1 0.1"/></mujocoinclude>'


def _scene(folder: Path, body: str, head: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "scene.xml"
    scene.write_text(f"<mujoco>{head}<worldbody>{body}</worldbody></mujoco>", encoding="utf-8")
    return scene


def test_includes_inside_the_folder_are_read(tmp_path: Path) -> None:
    (tmp_path / "scene" / "parts").mkdir(parents=True)
    (tmp_path / "scene" / "parts" / "box.xml").write_text(BOX, encoding="utf-8")
    scene = _scene(tmp_path / "scene", '<include file="parts/box.xml"/>')
    check_scene_files(scene)
    assert read_mujoco_interface(scene, None).content_hash


@pytest.mark.parametrize(
    ("body", "head", "what"),
    [
        ('<include file="../outside.xml"/>', "", "<include file> `../outside.xml`"),
        ('<include file="parts/../../outside.xml"/>', "", "<include file>"),
        ("", '<asset><mesh name="m" file="/abs/mesh.stl"/></asset>', "<mesh file> `/abs/mesh.stl`"),
        ("", '<compiler meshdir="../meshes"/>', "<compiler meshdir> `../meshes`"),
        ("", '<asset><texture name="t" type="2d" file="../t.png"/></asset>', "<texture file>"),
    ],
)
def test_a_path_leaving_the_folder_is_refused_before_mujoco_reads_it(
    tmp_path: Path, body: str, head: str, what: str
) -> None:
    (tmp_path / "outside.xml").write_text(BOX, encoding="utf-8")
    scene = _scene(tmp_path / "scene", body, head)
    with pytest.raises(ModelError, match="lies outside the scene's folder") as info:
        read_mujoco_interface(scene, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert what in str(info.value)


def test_a_nested_include_is_followed_and_checked(tmp_path: Path) -> None:
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "inner.xml").write_text(
        '<mujocoinclude><include file="../outside.xml"/></mujocoinclude>', encoding="utf-8"
    )
    scene = _scene(folder, '<include file="inner.xml"/>')
    with pytest.raises(ModelError, match=r"scene.xml \(in inner.xml\)"):
        check_scene_files(scene)


def test_a_link_inside_the_folder_pointing_outside_is_refused(tmp_path: Path) -> None:
    (tmp_path / "outside.xml").write_text(BOX, encoding="utf-8")
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "box.xml").symlink_to(tmp_path / "outside.xml")
    scene = _scene(folder, '<include file="box.xml"/>')
    with pytest.raises(ModelError, match="outside the scene's folder"):
        check_scene_files(scene)


def test_validate_reports_it_at_the_component_path(tmp_path: Path) -> None:
    (tmp_path / "outside.xml").write_text(BOX, encoding="utf-8")
    _scene(tmp_path / "scene", '<include file="../outside.xml"/>')
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: s\nrun: {stop: 1, step: 0.01}\n"
        "components:\n  world: {kind: mujoco, path: scene/scene.xml}\n",
        encoding="utf-8",
    )
    result = CliRunner().invoke(app, ["validate", str(system)])
    assert result.exit_code == 1
    assert "system.yaml:5:31: error[E017" in " ".join(result.output.split())
