"""ONNX components: graph inputs and outputs become ports."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field

from fmionnx.compile.ir import ComponentInterface
from fmionnx.spec.base import ComponentSpecBase


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


class OnnxKind:
    """Reads ONNX graph signatures."""

    name = "onnx"
    spec_model = OnnxSpec
    suffixes = (".onnx",)
    summary = "ONNX model run by onnxruntime"

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the model's inputs and outputs."""
        from fmionnx.kinds.onnx.interface import read_onnx_interface

        return read_onnx_interface(path)


ONNX_KIND = OnnxKind()
