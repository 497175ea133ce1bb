"""System-file keys of a ``mujoco`` component: its pydantic model, loaded only where a system
file or a lone model is compiled (a compiled system read back, a study's worker or an
isolated model's process needs none of pydantic)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from fmionnx.core.specbase import ComponentSpecBase, StrictModel


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
