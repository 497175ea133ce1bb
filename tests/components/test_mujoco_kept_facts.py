"""What a compile reads from a MuJoCo scene, kept in the cache folder
(``fmionnx.kinds.mujoco.keptfacts``): the same answers as MuJoCo's, a new entry when any file
of the scene changes, a tampered entry ignored, and a compile of an unchanged scene that does
not import MuJoCo."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fmionnx.core.cachedir import cache_folder
from fmionnx.kinds.mujoco import keptfacts
from fmionnx.kinds.mujoco.kind import MUJOCO_KIND
from fmionnx.kinds.mujoco.spec import MujocoSpec
from tests.conftest import REPO
from tests.keptstores import entries, forge

REFERENCE_SCENE = REPO / "models" / "world" / "sign_course.xml"

SCENE = """<mujoco>
  <include file="parts.xml"/>
  <worldbody>
    <site name="B" pos="3 1 0"/>
    <body name="cart" pos="0 0 0.1">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.1" rgba="1 0 0 1"/>
      <site name="nose" pos="0.1 0 0"/>
    </body>
    <geom name="board" type="box" pos="2 2 0.5" size="0.1 0.5 0.5" rgba="0 0 1 1"/>
  </worldbody>
  <actuator><motor name="push" joint="slide"/></actuator>
</mujoco>
"""
PARTS = """<mujoco><sensor><jointpos name="{name}" joint="slide"/></sensor></mujoco>"""


def _scene(folder: Path, sensor: str = "x") -> Path:
    folder.mkdir(exist_ok=True)
    (folder / "parts.xml").write_text(PARTS.format(name=sensor))
    scene = folder / "scene.xml"
    scene.write_text(SCENE)
    return scene


def _forget() -> None:
    """As a new process starts: nothing read yet in this one."""
    keptfacts._FACTS.clear()
    from fmionnx.kinds.mujoco import interface

    interface._MODELS.clear()


def _answers(scene: Path) -> tuple[object, ...]:
    spec = MujocoSpec(path=scene.name)
    interface = MUJOCO_KIND.read_interface(scene, spec)
    return interface, dict(MUJOCO_KIND.sites(scene)), MUJOCO_KIND.scene_map(scene)


@pytest.mark.parametrize("which", ["reference", "made here"])
def test_kept_answers_are_mujocos_own(which: str, tmp_path: Path, monkeypatch) -> None:
    scene = REFERENCE_SCENE if which == "reference" else _scene(tmp_path / "s")
    monkeypatch.setenv(keptfacts.STORE.switch, "0")
    _forget()
    read = _answers(scene)
    monkeypatch.delenv(keptfacts.STORE.switch)
    _forget()
    first = _answers(scene)  # read with MuJoCo, and kept
    _forget()
    kept = _answers(scene)  # from the cache folder
    assert len(entries(keptfacts.STORE)) == 1
    assert first == read
    assert kept == read


def test_an_included_file_that_changes_makes_a_new_entry(tmp_path: Path) -> None:
    scene = _scene(tmp_path / "s", sensor="before")
    _forget()
    assert MUJOCO_KIND.read_interface(scene, MujocoSpec(path="scene.xml")).port("before")
    (scene.parent / "parts.xml").write_text(PARTS.format(name="after"))
    _forget()
    interface = MUJOCO_KIND.read_interface(scene, MujocoSpec(path="scene.xml"))
    assert interface.port("after") is not None
    assert interface.port("before") is None
    assert len(entries(keptfacts.STORE)) == 2


def _age(folder: Path) -> None:
    """Every file in ``folder`` last modified a minute ago: older than the racy window."""
    old = time.time() - 60
    for file in folder.iterdir():
        os.utime(file, (old, old), follow_symlinks=False)


def test_a_long_running_process_sees_an_included_file_change(tmp_path: Path) -> None:
    """The editor's language server reads a scene again when a file it includes changes,
    though the scene's own file did not (it kept the first answer)."""
    from fmionnx.kinds.mujoco.interface import load_model

    scene = _scene(tmp_path / "s", sensor="before")
    _age(scene.parent)
    _forget()
    spec = MujocoSpec(path="scene.xml")
    assert MUJOCO_KIND.read_interface(scene, spec).port("before") is not None
    model, _ = load_model(scene)
    assert load_model(scene)[0] is model  # unchanged: the same loaded model
    (scene.parent / "parts.xml").write_text(PARTS.format(name="after_edit"))
    _age(scene.parent)
    interface = MUJOCO_KIND.read_interface(scene, spec)
    assert interface.port("after_edit") is not None
    assert interface.port("before") is None
    reloaded, _ = load_model(scene)
    assert reloaded is not model
    assert reloaded.nsensor == 1


def test_an_included_link_retargeted_is_a_change(tmp_path: Path) -> None:
    from fmionnx.kinds.mujoco.interface import load_model

    scene = _scene(tmp_path / "s")
    (scene.parent / "parts.xml").unlink()
    (scene.parent / "a.xml").write_text(PARTS.format(name="from_a"))
    (scene.parent / "b.xml").write_text(PARTS.format(name="from_b"))
    (scene.parent / "parts.xml").symlink_to("a.xml")
    _age(scene.parent)
    _forget()
    model, _ = load_model(scene)
    assert load_model(scene)[0] is model
    (scene.parent / "parts.xml").unlink()
    (scene.parent / "parts.xml").symlink_to("b.xml")
    _age(scene.parent)
    assert MUJOCO_KIND.read_interface(scene, MujocoSpec(path="scene.xml")).port("from_b")
    assert load_model(scene)[0] is not model


def test_a_scene_modified_just_before_it_was_read_is_read_again(tmp_path: Path) -> None:
    """Within its modification time's resolution a file can change unseen: an answer read
    right after a file changed is not given back (racily clean, as git has it)."""
    from fmionnx.kinds.mujoco.interface import load_model

    scene = _scene(tmp_path / "s")  # written just now
    _forget()
    model, _ = load_model(scene)
    assert load_model(scene)[0] is not model
    _age(scene.parent)
    settled, _ = load_model(scene)
    assert load_model(scene)[0] is settled


def test_a_tampered_entry_is_ignored(tmp_path: Path) -> None:
    scene = _scene(tmp_path / "s", sensor="honest")
    _forget()
    expected = _answers(scene)
    (entry,) = entries(keptfacts.STORE)
    forge(entry, b'"honest"', b'"forged"')
    _forget()
    assert _answers(scene) == expected


def test_switched_off_nothing_is_kept(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv(keptfacts.STORE.switch, "0")
    _forget()
    _answers(_scene(tmp_path / "s"))
    assert not cache_folder(keptfacts.STORE.folder).exists()


CHECK = """
import sys
from pathlib import Path
from fmionnx.kinds.mujoco.kind import MUJOCO_KIND
from fmionnx.kinds.mujoco.spec import MujocoSpec
scene = Path(sys.argv[1])
MUJOCO_KIND.read_interface(scene, MujocoSpec(path=scene.name))
MUJOCO_KIND.sites(scene)
MUJOCO_KIND.scene_map(scene)
print("mujoco" in sys.modules)
"""


def test_an_unchanged_scene_is_read_without_mujoco() -> None:
    runs = [
        subprocess.run(
            [sys.executable, "-c", CHECK, str(REFERENCE_SCENE)],
            env=dict(os.environ), capture_output=True, text=True, check=True,
        ).stdout.strip()
        for _ in range(2)
    ]  # fmt: skip
    assert runs == ["True", "False"]
