"""The table of component kinds: a kind is added here, in one place, explicitly."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from fmionnx.kinds.base import ComponentKind
from fmionnx.kinds.fmu.kind import FMU_KIND
from fmionnx.kinds.mujoco.kind import MUJOCO_KIND
from fmionnx.kinds.onnx.kind import ONNX_KIND

COMPONENT_KINDS: Mapping[str, ComponentKind] = {
    FMU_KIND.name: FMU_KIND,
    ONNX_KIND.name: ONNX_KIND,
    MUJOCO_KIND.name: MUJOCO_KIND,
}


def kind_for_path(path: Path) -> ComponentKind | None:
    """Guess a kind from a file name (for ``fmionnx inspect``), or None."""
    name = path.name.lower()
    for kind in COMPONENT_KINDS.values():
        if name.endswith(kind.suffixes):
            return kind
    if path.is_dir() and (path / "modelDescription.xml").is_file():
        return COMPONENT_KINDS["fmu"]
    return None
