"""Shipping a model copies the files it references, never the rest of its folder.

``compile --models``, ``export`` (SSP) and ``sweep`` (to its workers) copied a MuJoCo scene's
whole folder: an SSP export packed ``keys/id_rsa`` and ``secret.txt`` found beside a scene, a
link beside it to a large folder elsewhere went along, a link to ``/dev/zero`` filled a disk.
Each test builds a real scene (an include, a mesh and a height field in ``meshdir``, a 2D and a
cube texture in ``texturedir``) that MuJoCo compiles, beside files and links it never names,
and checks that exactly the named files travel -- and are enough: the shipped copy compiles to
the same model (the model store checks its content hash).
"""

from __future__ import annotations

import os
import struct
import tarfile
import zipfile
import zlib
from io import BytesIO
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.compile.systemfile import place_models, read_compiled, write_compiled
from fmionnx.core import modelfiles
from fmionnx.core.modelfiles import ShippingError
from fmionnx.kinds.mujoco.files import scene_files

#: What the scene names, relative to its folder (meshdir="meshes", texturedir="textures").
REFERENCED = {
    "scene.xml",
    "parts/box.xml",
    "meshes/tet.obj",
    "meshes/terrain.png",
    "textures/check.png",
    *(f"textures/sky/{face}.png" for face in "rludfb"),
}

SCENE = """<mujoco>
  <compiler meshdir="meshes" texturedir="textures"/>
  <asset>
    <mesh name="tet" file="tet.obj"/>
    <texture name="check" type="2d" file="check.png"/>
    <texture name="sky" type="skybox" fileright="sky/r.png" fileleft="sky/l.png"
      fileup="sky/u.png" filedown="sky/d.png" filefront="sky/f.png" fileback="sky/b.png"/>
    <material name="m" texture="check"/>
    <hfield name="ground" file="terrain.png" size="1 1 0.1 0.1"/>
  </asset>
  <worldbody>
    <include file="parts/box.xml"/>
    <geom type="mesh" mesh="tet" material="m"/>
    <geom type="hfield" hfield="ground" pos="0 3 0"/>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>
  </worldbody>
  <sensor><framepos name="p" objtype="body" objname="ball"/></sensor>
</mujoco>
"""


def _png(path: Path, size: int = 2) -> None:
    """A small RGB PNG (a checker), written by hand: no imaging library needed."""
    rows = b"".join(
        b"\0" + b"".join(bytes([200, 50 + 100 * ((x + y) % 2), 30]) for x in range(size))
        for y in range(size)
    )

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )  # fmt: skip


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    """The scene, beside what an attacker (or a messy folder) put there."""
    folder = tmp_path / "world"
    (folder / "parts").mkdir(parents=True)
    (folder / "parts" / "box.xml").write_text(
        '<mujocoinclude><geom name="box" type="box" size="0.1 0.1 0.1" pos="2 0 0"/>'
        "</mujocoinclude>"
    )
    (folder / "meshes").mkdir()
    (folder / "meshes" / "tet.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    _png(folder / "meshes" / "terrain.png", 4)
    _png(folder / "textures" / "check.png")
    for face in "rludfb":
        _png(folder / "textures" / "sky" / f"{face}.png")
    (folder / "scene.xml").write_text(SCENE)
    # never named by the scene:
    (folder / "keys").mkdir()
    (folder / "keys" / "id_rsa").write_text("-----BEGIN OPENSSH PRIVATE KEY-----\n")
    (folder / "secret.txt").write_text("not for the supplier\n")
    (folder / "meshes" / "unused.obj").write_text("v 0 0 0\n")
    big = tmp_path / "datasets"  # a large folder elsewhere, linked beside the scene
    big.mkdir()
    (big / "recording.bin").write_bytes(b"\0" * 100_000)
    (folder / "datasets").symlink_to(big)
    os.mkfifo(folder / "pipe")  # a reader that opens it waits for ever
    return folder / "scene.xml"


def _system(scene: Path) -> Path:
    path = scene.parent.parent / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: world\nrun: {stop: 0.01, step: 0.002}\n"
        f"components:\n  world: {{kind: mujoco, path: {scene}}}\n"
    )
    return path


def test_a_scene_ships_exactly_the_files_it_names(scene: Path) -> None:
    assert {f.name for f in scene_files(scene)} == REFERENCED


def test_compile_models_copies_only_the_referenced_files_and_they_suffice(
    scene: Path, tmp_path: Path
) -> None:
    store = tmp_path / "store"
    output = tmp_path / "world.fmionnx.json"
    args = ["compile", str(_system(scene)), "-o", str(output), "--models", str(store), "-q"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    (folder,) = [p for p in store.iterdir() if not p.name.startswith(".")]
    shipped = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}
    assert shipped == REFERENCED
    assert not any(p.is_symlink() for p in folder.rglob("*"))
    moved = read_compiled(output, models=store)  # reads the copy: the same content hash
    assert moved.component("world").path.is_relative_to(store)


def test_an_ssp_export_packs_only_the_files_the_scene_names(scene: Path, tmp_path: Path) -> None:
    output = tmp_path / "world.ssp"
    result = CliRunner().invoke(app, ["export", str(_system(scene)), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with zipfile.ZipFile(output) as archive:
        packed = {n.removeprefix("resources/world/") for n in archive.namelist()}
    assert packed - {"SystemStructure.ssd"} == REFERENCED


def test_a_sweep_sends_its_workers_only_the_files_the_scene_names(scene: Path) -> None:
    from fmionnx.backends.sweep.models import pack_models

    system = fmionnx.load(_system(scene)).compiled
    (archive,) = pack_models(system).values()
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        members = {m.name for m in tar.getmembers() if m.isfile()}
    assert members == REFERENCED


def test_a_named_file_that_is_no_regular_file_is_refused(scene: Path) -> None:
    scene.write_text(scene.read_text().replace('file="check.png"', 'file="pipe"'))
    (scene.parent / "textures" / "pipe").symlink_to(scene.parent / "pipe")
    with pytest.raises(ShippingError, match="is not a regular file"):
        scene_files(scene)


def test_files_larger_than_the_bound_are_refused_before_anything_is_copied(
    scene: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(modelfiles, "MAX_SHIPPED_BYTES", 1000)
    system = fmionnx.load(_system(scene)).compiled
    with pytest.raises(ShippingError, match="a model ships at most 1000 bytes"):
        place_models(system, tmp_path / "store")
    assert [p for p in (tmp_path / "store").rglob("*") if p.is_file()] == []


def test_an_unpacked_model_with_a_link_out_of_its_folder_is_refused(
    fixture_fmu, tmp_path: Path
) -> None:
    """An unpacked FMU is a folder: all of it ships, but never a file it links to outside."""
    folder = tmp_path / "Gain"
    with zipfile.ZipFile(fixture_fmu("Gain")) as archive:
        archive.extractall(folder)
    (tmp_path / "secret.txt").write_text("mine\n")
    (folder / "resources").mkdir(exist_ok=True)
    (folder / "resources" / "notes.txt").symlink_to(tmp_path / "secret.txt")
    system = tmp_path / "gain.yaml"
    system.write_text(
        "fmionnx: 1\nname: gain\nrun: {stop: 0.01, step: 0.01}\n"
        f"components:\n  gain: {{kind: fmu, path: {folder}}}\n"
    )
    compiled = fmionnx.load(system).compiled
    with pytest.raises(ShippingError, match="lies outside the model's folder"):
        place_models(compiled, tmp_path / "store")
    output = tmp_path / "gain.ssp"
    result = CliRunner().invoke(app, ["export", str(system), "-o", str(output)])
    assert result.exit_code == 1
    assert "lies outside the model's folder" in result.output
    assert not output.exists()
    write_compiled(compiled, tmp_path / "gain.fmionnx.json")  # the system itself is fine
