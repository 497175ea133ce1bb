"""One runner per component kind, registered explicitly in :data:`RUNNER_FACTORIES`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from fmionnx.compile.ir import Component
from fmionnx.core.runner import Runner


@dataclass(frozen=True, slots=True)
class Wiring:
    """What a runner needs to know about the system around it, decided by the master.

    ``driven``: ports that connections write into (parameters among them become run-time
    inputs). ``sizes``: element counts arriving at each driven port (fixes symbolic ONNX dims).
    """

    driven: frozenset[str] = frozenset()
    sizes: Mapping[str, int] | None = None


def _fmu(component: Component, wiring: Wiring) -> Runner:
    from fmionnx.kinds.fmu.runner import FmuRunner

    return FmuRunner(component, wiring.driven)


def _onnx(component: Component, wiring: Wiring) -> Runner:
    from fmionnx.kinds.onnx.runner import OnnxRunner

    return OnnxRunner(component, dict(wiring.sizes or {}))


def _mujoco(component: Component, wiring: Wiring) -> Runner:
    from fmionnx.kinds.mujoco.runner import MujocoRunner

    return MujocoRunner(component)


#: Kind name -> factory. Heavy libraries are imported only when a runner is made.
RUNNER_FACTORIES: Mapping[str, Callable[[Component, Wiring], Runner]] = {
    "fmu": _fmu,
    "onnx": _onnx,
    "mujoco": _mujoco,
}


def make_runner(component: Component, wiring: Wiring | None = None) -> Runner:
    """The runner for ``component`` (KeyError for a kind without a runner: a compiler bug)."""
    return RUNNER_FACTORIES[component.kind](component, wiring or Wiring())
