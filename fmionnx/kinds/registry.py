"""The table of component kinds: a kind is added here, in one place, explicitly.

Everything else asks this table (by a component's ``kind`` name) for what a kind does; no
module outside a kind's own names it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core.types import Component, KindConfig
from fmionnx.kinds.base import ComponentKind
from fmionnx.kinds.fmu.kind import FMU_KIND
from fmionnx.kinds.mujoco.kind import MUJOCO_KIND
from fmionnx.kinds.onnx.kind import ONNX_KIND
from fmionnx.kinds.signal.kind import SIGNAL_KIND

if TYPE_CHECKING:
    from fmionnx.core.runner import Runner, Wiring

COMPONENT_KINDS: Mapping[str, ComponentKind] = {
    FMU_KIND.name: FMU_KIND,
    ONNX_KIND.name: ONNX_KIND,
    MUJOCO_KIND.name: MUJOCO_KIND,
    SIGNAL_KIND.name: SIGNAL_KIND,
}


def kind_of(component: Component) -> ComponentKind:
    """The kind object of a compiled component (KeyError for an unknown kind: a bug)."""
    return COMPONENT_KINDS[component.kind]


def has_capability(component: Component, capability: str) -> bool:
    """Whether the component's kind declares ``capability`` (see :mod:`fmionnx.kinds.base`)."""
    kind = COMPONENT_KINDS.get(component.kind)
    return kind is not None and capability in kind.capabilities


def config_type(kind: str) -> type[KindConfig]:
    """The config class of ``kind`` (for reading serialised systems); KeyError when unknown."""
    return COMPONENT_KINDS[kind].config_type


def make_runner(component: Component, wiring: Wiring | None = None) -> Runner:
    """The runner for ``component``: the default runner factory of the runtime."""
    from fmionnx.core.runner import Wiring  # brings numpy: only when a runner is made

    return kind_of(component).make_runner(component, wiring or Wiring())


def kind_for_path(path: Path) -> ComponentKind | None:
    """Guess a kind from a file name (for ``fmionnx inspect``), or None."""
    name = path.name.lower()
    for kind in COMPONENT_KINDS.values():
        if kind.suffixes and name.endswith(kind.suffixes):
            return kind
    if path.is_dir() and (path / "modelDescription.xml").is_file():
        return FMU_KIND
    return None
