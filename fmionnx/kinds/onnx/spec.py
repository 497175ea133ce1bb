"""System-file keys of a ``onnx`` component: its pydantic model, loaded only where a system
file or a lone model is compiled (a compiled system read back, a study's worker or an
isolated model's process needs none of pydantic)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from fmionnx.core.specbase import ComponentSpecBase


class OnnxSpec(ComponentSpecBase):
    """System-file keys of an ``onnx`` component."""

    kind: Literal["onnx"] = "onnx"
    providers: list[str] = Field(
        default_factory=lambda: ["CPUExecutionProvider"],
        description="onnxruntime execution providers, in order of preference.",
    )
    threads: int | None = Field(
        default=None, ge=1, description="Intra-op threads of the session (default: onnxruntime's)."
    )
    units: dict[str, str] = Field(
        default_factory=dict,
        description="Units of ports by port name (`{speed: km/h}`): an ONNX graph declares "
        "none. Built-in names (m, km, s, h, m/s, km/h, rad, deg, K, degC, N ...) are converted "
        "on connections; other names are compared as written.",
    )
