"""MuJoCo components: sensors are outputs, actuators inputs, cameras image outputs."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from fmionnx.core.types import Component, ComponentInterface, KindConfig
from fmionnx.kinds.base import (
    CAMERA,
    MAP,
    SIMULATOR,
    SITES,
    Display,
    KindProblem,
    RoleDefault,
    SceneMap,
    SettingInput,
    Site,
)

if TYPE_CHECKING:  # the runner contract brings numpy: loaded when a runner is made
    from fmionnx.core.modelfiles import ModelFile
    from fmionnx.core.runner import Runner, Wiring
    from fmionnx.core.specbase import ComponentSpecBase


@dataclass(frozen=True, slots=True)
class CameraConfig:
    """One camera to render offscreen, by its name in the scene."""

    name: str
    width: int
    height: int


@dataclass(frozen=True, slots=True)
class MujocoConfig(KindConfig):
    """Resolved settings of a MuJoCo component."""

    kind: str = "mujoco"
    cameras: tuple[CameraConfig, ...] = ()
    gl: Literal["auto", "egl", "osmesa"] = "auto"
    #: Scene values a study set (``body.sign.pos``: numbers), applied to the loaded model
    #: before the first step; see :mod:`fmionnx.kinds.mujoco.scenevalues`.
    scene_values: tuple[tuple[str, tuple[float, ...]], ...] = ()


_POSITION = tuple(f"pose.pose.position.{a}" for a in "xyz")
_ORIENTATION = tuple(f"pose.pose.orientation.{a}" for a in "wxyz")  # MuJoCo order w, x, y, z
_TWIST = "geometry_msgs/msg/Twist"
_ODOMETRY = "nav_msgs/msg/Odometry"


class MujocoKind:
    """Reads a MuJoCo scene's sensors, actuators and cameras."""

    name = "mujoco"
    config_type = MujocoConfig
    suffixes = (".xml", ".mjcf", ".mjb")
    summary = "MuJoCo physics scene (sensors, actuators, cameras)"
    mime_type = "application/x-mujoco+xml"
    capabilities = frozenset({SIMULATOR, CAMERA, SITES, MAP})
    libraries = ("mujoco",)
    display = Display(
        "MuJoCo",
        'shape=box3d, style="filled", fillcolor="#dcfce7", color="#15803d"',
        ("[(", ")]"),
        "#dcfce7",
    )
    #: The robot's velocity command and pose: ``/cmd_vel`` and ``/odom`` as a ROS robot has them.
    ros2_defaults: Mapping[tuple[str, str], RoleDefault] = {
        ("cmd_v", "input"): RoleDefault("cmd_vel", _TWIST, ("linear.x",)),
        ("cmd_w", "input"): RoleDefault("cmd_vel", _TWIST, ("angular.z",)),
        ("base_pos", "output"): RoleDefault("odom", _ODOMETRY, _POSITION),
        ("base_quat", "output"): RoleDefault("odom", _ODOMETRY, _ORIENTATION),
    }

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The entry's pydantic model (:mod:`.spec`), loaded on first use."""
        from fmionnx.kinds.mujoco.spec import MujocoSpec

        return MujocoSpec

    def check(
        self, spec: ComponentSpecBase, interface: ComponentInterface
    ) -> tuple[KindProblem, ...]:
        """Nothing beyond the interface reader's own checks."""
        return ()

    def validate_model(self, path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
        """Nothing more: reading the interface compiled the scene with MuJoCo's own compiler
        (``MjModel.from_xml_path``), which is MuJoCo's validation of a scene."""
        return ()

    def resolve(self, spec: ComponentSpecBase, interface: ComponentInterface) -> MujocoConfig:
        """Cameras in the order the entry lists them."""
        from fmionnx.kinds.mujoco.spec import MujocoSpec  # pydantic: loaded with the entry

        assert isinstance(spec, MujocoSpec)
        cameras = tuple(CameraConfig(n, c.width, c.height) for n, c in spec.cameras.items())
        return MujocoConfig(cameras=cameras, gl=spec.gl)

    def settings(self, component: Component) -> tuple[str, ...]:
        """The values the scene exposes (fixed bodies' positions, ``<numeric>`` fields)."""
        from fmionnx.kinds.mujoco.scenevalues import scene_values

        return tuple(scene_values(component.path))

    def with_setting(self, component: Component, name: str, value: SettingInput) -> MujocoConfig:
        """The config with scene value ``name`` set (SettingError when the scene has no such
        value or the numbers do not fit it)."""
        from fmionnx.kinds.mujoco.scenevalues import checked_value

        config = component.config
        assert isinstance(config, MujocoConfig)
        numbers = checked_value(component.path, component.name, name, value)
        kept = tuple((n, v) for n, v in config.scene_values if n != name)
        return dataclasses.replace(config, scene_values=(*kept, (name, numbers)))

    def setting_hint(self, component: Component, name: str) -> str | None:
        """A body that moves is named as such: only bodies fixed to the world are settings."""
        from fmionnx.kinds.mujoco.scenevalues import moving_body_hint

        return moving_body_hint(component.path, name)

    def model_files(self, path: Path) -> tuple[ModelFile, ...]:
        """The scene, its includes and the assets it names (never the rest of its folder)."""
        from fmionnx.kinds.mujoco.files import scene_files

        return scene_files(path)

    def confined_environment(self, component: Component) -> Mapping[str, str]:
        """``MUJOCO_GL``: the OpenGL backend that works, probed here (the probe is a process
        of its own, which a sandboxed process cannot start); empty when none works (the
        runner then says so, as without a sandbox)."""
        config = component.config
        if not isinstance(config, MujocoConfig) or not config.cameras:
            return {}  # nothing to render
        from fmionnx.kinds.mujoco.gl import backend_for

        backend = backend_for(config.gl)
        return {} if backend is None else {"MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}

    def for_workers(self) -> None:
        """A study's worker keeps a scene and its cameras' GL contexts for the scene's next
        cases (:mod:`fmionnx.kinds.kept`)."""
        from fmionnx.kinds.mujoco.runner import keep_scenes

        keep_scenes()

    def make_runner(self, component: Component, wiring: Wiring) -> Runner:
        """A :class:`~fmionnx.kinds.mujoco.runner.MujocoRunner` (loads mujoco only now)."""
        from fmionnx.kinds.mujoco.runner import MujocoRunner

        return MujocoRunner(component)

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the scene's ports."""
        from fmionnx.kinds.mujoco.interface import read_mujoco_interface
        from fmionnx.kinds.mujoco.spec import MujocoSpec  # pydantic: loaded with the entry

        cameras = None
        if isinstance(spec, MujocoSpec):
            cameras = {name: (c.width, c.height) for name, c in spec.cameras.items()}
        return read_mujoco_interface(path, cameras)

    def sites(self, path: Path) -> Mapping[str, Site]:
        """The scene's named sites: the landmarks checks measure distances to."""
        from fmionnx.kinds.mujoco.keptfacts import scene_facts
        from fmionnx.kinds.mujoco.sites import read_sites

        kept = scene_facts(path).sites
        return dict(kept) if kept is not None else read_sites(path)

    def scene_map(self, path: Path) -> SceneMap:
        """The scene's fixed landmarks seen from above: what trajectory plots draw underneath."""
        from fmionnx.kinds.mujoco.keptfacts import scene_facts
        from fmionnx.kinds.mujoco.scenemap import read_scene_map

        kept = scene_facts(path).scene_map
        return kept if kept is not None else read_scene_map(path)


MUJOCO_KIND = MujocoKind()
