"""The table of component kinds: a kind is added here, in one place, explicitly.

Everything else asks this table (by a component's ``kind`` name) for what a kind does; no
module outside a kind's own names it.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core.types import Component, KindConfig
from fmionnx.kinds.base import ComponentKind

if TYPE_CHECKING:
    from fmionnx.core.modelfiles import ModelFile
    from fmionnx.core.runner import Runner, Wiring


class _KindTable(Mapping[str, ComponentKind]):
    """Kind name -> kind object; a kind's module is imported when the kind is first used.

    A run of one FMU uses one kind: the others' modules (their pydantic entry models,
    waveform tables, scene types) cost a start that uses none of them (issue #14). Names,
    ``in`` and ``len`` need no import; ``values()`` and ``items()`` import every kind.
    """

    def __init__(self, modules: Mapping[str, tuple[str, str]]) -> None:
        self._modules = dict(modules)
        self._loaded: dict[str, ComponentKind] = {}

    def __getitem__(self, name: str) -> ComponentKind:
        kind = self._loaded.get(name)
        if kind is None:
            module, attribute = self._modules[name]  # KeyError: not a kind
            kind = getattr(importlib.import_module(module), attribute)
            if getattr(kind, "name", None) != name:
                msg = f"`{module}.{attribute}` is not the component kind `{name}`"
                raise TypeError(msg)
            self._loaded[name] = kind
        return kind

    def __contains__(self, name: object) -> bool:
        return name in self._modules

    def __iter__(self) -> Iterator[str]:
        return iter(self._modules)

    def __len__(self) -> int:
        return len(self._modules)


#: Every kind: its name, and the module and object that define it (in this order: the order
#: of the system-file union, of run.json's library versions and of listings).
COMPONENT_KINDS: Mapping[str, ComponentKind] = _KindTable(
    {
        "fmu": ("fmionnx.kinds.fmu.kind", "FMU_KIND"),
        "onnx": ("fmionnx.kinds.onnx.kind", "ONNX_KIND"),
        "mujoco": ("fmionnx.kinds.mujoco.kind", "MUJOCO_KIND"),
        "signal": ("fmionnx.kinds.signal.kind", "SIGNAL_KIND"),
    }
)

#: The libraries each kind runs on (its ``libraries``), known without importing the kinds:
#: ``run.json`` records their versions for every run. tests/kinds/test_lazy_registry.py keeps
#: this equal to the kinds' own declarations.
KIND_LIBRARIES: Mapping[str, tuple[str, ...]] = {
    "fmu": ("fmpy",),
    "onnx": ("onnxruntime",),
    "mujoco": ("mujoco",),
    "signal": (),
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


def model_files(kind: str, path: Path) -> tuple[ModelFile, ...]:
    """The files the model at ``path`` of kind ``kind`` is shipped with (see ``ShipsFiles``):
    the kind's list, else the model file alone, or every file of an unpacked model folder."""
    from fmionnx.core.modelfiles import model_file_alone, model_folder_tree
    from fmionnx.kinds.base import ShipsFiles

    found = COMPONENT_KINDS[kind]
    if isinstance(found, ShipsFiles):
        return found.model_files(path)
    return model_folder_tree(path) if path.is_dir() else model_file_alone(path)


def confined_environment(component: Component) -> Mapping[str, str]:
    """What the kind of ``component`` hands a process it confines (see ``ConfinedStart``)."""
    from fmionnx.kinds.base import ConfinedStart

    kind = kind_of(component)
    return kind.confined_environment(component) if isinstance(kind, ConfinedStart) else {}


def make_runner(component: Component, wiring: Wiring | None = None) -> Runner:
    """The runner for ``component``: the default runner factory of the runtime."""
    from fmionnx.core.runner import Wiring  # brings numpy: only when a runner is made

    return kind_of(component).make_runner(component, wiring or Wiring())


def result_aliases(component: Component) -> dict[str, str]:
    """Results column -> the name a lone model's results use (:class:`~.base.ResultNames`;
    by port for a kind that does not name them)."""
    from fmionnx.core.signals import column_names
    from fmionnx.core.types import Causality
    from fmionnx.kinds.base import ResultNames

    kind = kind_of(component)
    if isinstance(kind, ResultNames):
        return kind.result_aliases(component)
    return {
        column: column.split(".", 1)[1]  # the port and its element, without the component
        for port in component.interface.with_causality(Causality.OUTPUT)
        for column in column_names(component.name, port)
    }


def settle_worker() -> None:
    """Every kind's settings for a study's worker (:class:`~.base.WorkerSettings`)."""
    from fmionnx.kinds.base import WorkerSettings

    for kind in COMPONENT_KINDS.values():
        if isinstance(kind, WorkerSettings):
            kind.for_workers()


def process_reusable(component: Component) -> bool:
    """Whether a process that ran ``component`` may run it again (:class:`~.base.SharedProcess`;
    a kind without the protocol allows it)."""
    from fmionnx.kinds.base import SharedProcess

    kind = kind_of(component)
    return kind.process_reusable(component) if isinstance(kind, SharedProcess) else True


def warm_up() -> None:
    """Import what the runners of every kind that asks for it need (:class:`~.base.WarmUp`)."""
    from fmionnx.kinds.base import WarmUp

    for kind in COMPONENT_KINDS.values():
        if isinstance(kind, WarmUp):
            kind.warm_up()


#: The file name endings each kind reads (its ``suffixes``), known without importing the kinds:
#: a lone model loads its own kind only. tests/kinds/test_lazy_registry.py keeps this equal to
#: the kinds' own declarations.
KIND_SUFFIXES: Mapping[str, tuple[str, ...]] = {
    "fmu": (".fmu",),
    "onnx": (".onnx",),
    "mujoco": (".xml", ".mjcf", ".mjb"),
    "signal": (".csv",),
}


def model_root(path: Path) -> Path:
    """The model a path names: an unpacked FMU's ``modelDescription.xml`` names its folder
    (not a MuJoCo scene, which is XML too)."""
    return path.parent if path.name == "modelDescription.xml" else path


def kind_for_path(path: Path) -> ComponentKind | None:
    """Guess a kind from a file name (for ``fmionnx inspect``), or None; only that kind's
    module is imported."""
    name = path.name.lower()
    for kind_name, suffixes in KIND_SUFFIXES.items():
        if suffixes and name.endswith(suffixes):
            return COMPONENT_KINDS[kind_name]
    if path.is_dir() and (path / "modelDescription.xml").is_file():
        return COMPONENT_KINDS["fmu"]  # an unpacked FMU
    return None
