"""Measure what the sign course's visual settings cost per camera frame, and what they change.

Each *setting* is an edit of the scene's XML (anti-aliasing samples, skybox, floor texture,
shadows, reflections, fog, haze, lights). For a list of settings, the scene is rendered with
and without each one at the same seeded camera poses (those of ``measure_detector.py``), the
variants interleaved pose by pose so that a load change on the machine hits them all alike;
reported per setting:

* **ms per frame** with and without it (median over poses; ``update_scene`` + ``render`` into
  a preallocated frame, the runner's call), and the difference;
* **pixels changed**: share of pixels whose RGB differs;
* **detector**: the detection rate, false detections and the largest blobX error against the
  board's true pixels (segmentation), computed with the ONNX detector on both variants.

``BEFORE`` lists the settings the scene had before issue 14 (``before_scene`` re-applies them),
so the benchmark can show the render time before and after.

Usage: ``python models/measure_rendering.py [--frames 40] [--seed 1]`` after ``make models``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # measure_detector, next to this script

import measure_detector as md  # noqa: E402

Edit = Callable[[ElementTree.Element], None]


def _child(parent: ElementTree.Element, tag: str) -> ElementTree.Element:
    found = parent.find(tag)
    return found if found is not None else ElementTree.SubElement(parent, tag)


def _quality(root: ElementTree.Element, **attributes: str) -> None:
    _child(_child(root, "visual"), "quality").attrib.update(attributes)


def _map(root: ElementTree.Element, **attributes: str) -> None:
    _child(_child(root, "visual"), "map").attrib.update(attributes)


def _floor(root: ElementTree.Element) -> ElementTree.Element:
    for material in root.iter("material"):
        if material.get("name") == "floor":
            return material
    raise KeyError("floor material")


def anti_aliasing(root: ElementTree.Element) -> None:
    """4x multisampling of the offscreen buffer (MuJoCo's default ``offsamples``)."""
    _quality(root, offsamples="4")


def skybox(root: ElementTree.Element) -> None:
    """The light gradient sky of the first scene (without it the background is black)."""
    asset = _child(root, "asset")
    if not any(t.get("type") == "skybox" for t in asset.iter("texture")):
        sky = ElementTree.Element(
            "texture",
            name="sky",
            type="skybox",
            builtin="gradient",
            rgb1="0.88 0.9 0.92",
            rgb2="0.75 0.77 0.8",
            width="256",
            height="256",
        )
        asset.insert(0, sky)


def floor_texture(root: ElementTree.Element) -> None:
    """The checker texture on the floor (10x10 repeats)."""
    asset = _child(root, "asset")
    if not any(t.get("name") == "floor_tex" for t in asset.iter("texture")):
        texture = ElementTree.Element(
            "texture",
            name="floor_tex",
            type="2d",
            builtin="checker",
            rgb1="0.62 0.62 0.60",
            rgb2="0.55 0.55 0.53",
            width="256",
            height="256",
        )
        asset.insert(0, texture)
    floor = _floor(root)
    floor.set("texture", "floor_tex")
    floor.set("texrepeat", "10 10")
    floor.attrib.pop("rgba", None)


def shadows(root: ElementTree.Element) -> None:
    """A 4096 shadow map and a directional light casting shadows (the headlight casts none)."""
    _quality(root, shadowsize="4096")
    second_light(root)
    for light in root.iter("light"):
        light.set("castshadow", "true")


def reflections(root: ElementTree.Element) -> None:
    """A reflective floor (reflectance 0.2: MuJoCo renders the scene mirrored once more)."""
    _floor(root).set("reflectance", "0.2")


def fog(root: ElementTree.Element) -> None:
    """Fog from 3 to 10 m: drawn only where the renderer's ``mjRND_FOG`` flag is on, which
    MuJoCo's default scene options (and so fmionnx's renderer) leave off."""
    _map(root, fogstart="3", fogend="10")


def haze(root: ElementTree.Element) -> None:
    """Haze at the horizon of the skybox (MuJoCo's default 0.3; nothing without a skybox)."""
    _map(root, haze="0.3")


def second_light(root: ElementTree.Element) -> None:
    """A second directional light besides the headlight (the first scene's ``sun``)."""
    world = _child(root, "worldbody")
    if not any(light.get("name") == "sun" for light in world.iter("light")):
        sun = ElementTree.Element(
            "light",
            name="sun",
            directional="true",
            pos="0 0 6",
            dir="0.2 0.3 -1",
            diffuse="0.5 0.5 0.5",
            castshadow="false",
        )
        world.insert(0, sun)


#: Settings measured by default: name -> edit that turns the setting on.
SETTINGS: dict[str, Edit] = {
    "anti-aliasing 4x": anti_aliasing,
    "skybox": skybox,
    "floor texture": floor_texture,
    "second light": second_light,
    "shadows": shadows,
    "reflections": reflections,
    "fog": fog,
    "haze": haze,
}

#: The settings of the scene before issue 14 that the committed scene turned off.
BEFORE = ("anti-aliasing 4x", "skybox", "floor texture", "second light")


def scene_text(edits: Sequence[Edit] = (), scene: Path = md.SCENE) -> str:
    """The scene's XML with ``edits`` applied (its comments are dropped; nothing else)."""
    root = ElementTree.parse(scene).getroot()
    for edit in edits:
        edit(root)
    return ElementTree.tostring(root, encoding="unicode")


def before_scene(scene: Path = md.SCENE) -> str:
    """The scene with the visual settings it had before issue 14."""
    return scene_text([SETTINGS[name] for name in BEFORE], scene)


@dataclass
class Variant:
    """One scene under measurement: its renderer and what was measured on it."""

    name: str
    model: mujoco.MjModel
    data: mujoco.MjData
    renderer: mujoco.Renderer
    frame: np.ndarray
    times: list[float]
    images: list[np.ndarray]

    @classmethod
    def load(cls, name: str, xml: str) -> Variant:
        """Compile ``xml`` and open a 640x480 offscreen renderer on it."""
        model = mujoco.MjModel.from_xml_string(xml)
        renderer = mujoco.Renderer(model, md.HEIGHT, md.WIDTH)
        frame = np.zeros((md.HEIGHT, md.WIDTH, 3), np.uint8)
        return cls(name, model, mujoco.MjData(model), renderer, frame, [], [])

    def render(self, pose: tuple[float, float, float], keep: bool) -> None:
        """Place the robot at ``pose``; time one render of the ``front`` camera."""
        place(self.model, self.data, pose)
        started = time.perf_counter()
        self.renderer.update_scene(self.data, "front")
        self.renderer.render(out=self.frame)
        self.times.append(time.perf_counter() - started)
        if keep:
            self.images.append(self.frame.copy())

    def median_ms(self) -> float:
        """Median render time per frame in milliseconds."""
        return 1e3 * statistics.median(self.times)


def gl_renderer(scene: Path = md.SCENE) -> str:
    """The OpenGL renderer MuJoCo's offscreen context runs on, e.g. ``llvmpipe (LLVM 15.0.6,
    256 bits)`` (Mesa's software rasteriser) or a GPU's name under hardware EGL."""
    from OpenGL import GL

    model = mujoco.MjModel.from_xml_path(str(scene))
    renderer = mujoco.Renderer(model, 8, 8)
    try:
        renderer.update_scene(mujoco.MjData(model))
        renderer.render()
        name = GL.glGetString(GL.GL_RENDERER)
    finally:
        renderer.close()
    return name.decode() if isinstance(name, bytes) else str(name)


def place(model: mujoco.MjModel, data: mujoco.MjData, pose: tuple[float, float, float]) -> None:
    """Put the robot's base at (x, y, heading) on the floor and update the kinematics."""
    x, y, heading = pose
    base = model.joint("base").qposadr[0]
    data.qpos[base : base + 7] = [x, y, 0.05, np.cos(heading / 2), 0, 0, np.sin(heading / 2)]
    mujoco.mj_forward(model, data)


def time_variants(
    xmls: dict[str, str], poses: Sequence[tuple[float, float, float]], repeats: int = 2
) -> dict[str, Variant]:
    """Render every variant at every pose, interleaved; the first pass is a warm-up whose
    images are kept, the timed passes follow."""
    variants = {name: Variant.load(name, xml) for name, xml in xmls.items()}
    try:
        for sweep in range(repeats + 1):
            for pose in poses:
                for variant in variants.values():
                    variant.render(pose, keep=sweep == 0)
            if sweep == 0:
                for variant in variants.values():
                    variant.times.clear()
    finally:
        for variant in variants.values():
            variant.renderer.close()
    return variants


def detector_accuracy(images: Sequence[np.ndarray], truth: Sequence[md.Frame]) -> dict[str, float]:
    """Detection rate, false detections and blobX error of the ONNX detector on ``images``,
    against the boards' true pixels in ``truth`` (same poses); ``onnx_vs_numpy`` is the largest
    difference from the numpy measure (0: bit-identical)."""
    session = md.detector_session()
    visible = detected = absent = false = 0
    worst = 0.0
    errors: list[float] = []
    for image, frame in zip(images, truth, strict=True):
        blob_x, blob_size = session.run(None, {"image": image[np.newaxis]})
        ref_x, ref_size = (r.astype(np.float32) for r in md.numpy_blobs(image))
        worst = max(
            worst,
            float(np.abs(blob_x[0] - ref_x).max()),
            float(np.abs(blob_size[0] - ref_size).max()),
        )
        for colour, columns in enumerate(frame.board_columns):
            seen = bool(blob_size[0, colour] > 0)
            if columns.size >= md.MIN_PIXELS:
                visible += 1
                detected += int(seen)
                if seen:
                    errors.append(abs(float(blob_x[0, colour]) - float(columns.mean())))
            elif columns.size == 0:
                absent += 1
                false += int(seen)
    return {
        "onnx_vs_numpy": worst,
        "visible": float(visible),
        "detection_rate": detected / visible if visible else float("nan"),
        "false_detections": float(false),
        "blobX_error_max_px": max(errors) if errors else 0.0,
        "blobX_error_mean_px": float(np.mean(errors)) if errors else 0.0,
    }


@dataclass(frozen=True)
class SettingCost:
    """What one setting costs and changes."""

    setting: str
    off_ms: float
    on_ms: float
    changed_pixels: float
    accuracy_off: dict[str, float]
    accuracy_on: dict[str, float]


def measure(
    frames: int, seed: int, settings: Sequence[str] = tuple(SETTINGS), repeats: int = 2
) -> list[SettingCost]:
    """Each setting on against the committed scene (off), at ``frames`` seeded poses."""
    poses = md.sample_poses(frames, seed)
    truth = list(md.render_frames(poses))  # segmentation of the committed scene's geometry
    xmls = {"scene": scene_text()}
    xmls.update({name: scene_text([SETTINGS[name]]) for name in settings})
    variants = time_variants(xmls, poses, repeats)
    base = variants["scene"]
    base_accuracy = detector_accuracy(base.images, truth)
    costs = []
    for name in settings:
        on = variants[name]
        changed = np.mean(
            [np.any(a != b, axis=2).mean() for a, b in zip(on.images, base.images, strict=True)]
        )
        costs.append(
            SettingCost(
                name,
                base.median_ms(),
                on.median_ms(),
                float(changed),
                base_accuracy,
                detector_accuracy(on.images, truth),
            )
        )
    return costs


def main(argv: list[str] | None = None) -> int:
    """Print the costs as a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    costs = measure(args.frames, args.seed, repeats=args.repeats)
    print(
        "| setting | off ms | on ms | cost ms | pixels changed | detection off / on "
        "| blobX max error off / on (px) | false detections on |\n|---|---|---|---|---|---|---|---|"
    )
    for c in costs:
        print(
            f"| {c.setting} | {c.off_ms:.2f} | {c.on_ms:.2f} | {c.on_ms - c.off_ms:+.2f} "
            f"| {100 * c.changed_pixels:.1f} % | {c.accuracy_off['detection_rate']:.3f} / "
            f"{c.accuracy_on['detection_rate']:.3f} | {c.accuracy_off['blobX_error_max_px']:.2f} / "
            f"{c.accuracy_on['blobX_error_max_px']:.2f} | {c.accuracy_on['false_detections']:.0f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
