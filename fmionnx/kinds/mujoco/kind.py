"""MuJoCo components: sensors are outputs, actuators inputs, cameras image outputs."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field

from fmionnx.compile.ir import ComponentInterface
from fmionnx.spec.base import ComponentSpecBase, StrictModel


class CameraSpec(StrictModel):
    """Offscreen rendering of one named camera of the scene."""

    width: int = Field(default=640, ge=1, le=8192)
    height: int = Field(default=480, ge=1, le=8192)


class MujocoSpec(ComponentSpecBase):
    """System-file keys of a ``mujoco`` component."""

    kind: Literal["mujoco"] = "mujoco"
    cameras: dict[str, CameraSpec] = Field(
        default_factory=dict,
        description="Cameras to render, by name in the scene; each becomes an output port "
        "`uint8[height,width,3]`. Rendered only when a consumer is due.",
    )
    gl: Literal["auto", "egl", "osmesa"] = Field(
        default="auto",
        description="Offscreen OpenGL backend; `auto` tries EGL then OSMesa (MUJOCO_GL wins).",
    )


class MujocoKind:
    """Reads a MuJoCo scene's sensors, actuators and cameras."""

    name = "mujoco"
    spec_model = MujocoSpec
    suffixes = (".xml", ".mjcf", ".mjb")
    summary = "MuJoCo physics scene (sensors, actuators, cameras)"

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the scene's ports."""
        from fmionnx.kinds.mujoco.interface import read_mujoco_interface

        cameras = None
        if isinstance(spec, MujocoSpec):
            cameras = {name: (c.width, c.height) for name, c in spec.cameras.items()}
        return read_mujoco_interface(path, cameras)


MUJOCO_KIND = MujocoKind()
