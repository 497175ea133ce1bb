"""ONNX components: graph inputs and outputs become ports."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core.types import Component, ComponentInterface, KindConfig
from fmionnx.kinds.base import (
    EVALUATED_AT_START,
    FILE_HASHED,
    TIMELESS,
    Display,
    KindProblem,
    RoleDefault,
)
from fmionnx.kinds.onnx.units import unit_problems, with_units

if TYPE_CHECKING:  # the runner contract brings numpy: loaded when a runner is made
    from fmionnx.core.runner import Runner, Wiring
    from fmionnx.core.specbase import ComponentSpecBase


@dataclass(frozen=True, slots=True)
class OnnxConfig(KindConfig):
    """Resolved settings of an ONNX component."""

    kind: str = "onnx"
    providers: tuple[str, ...] = ("CPUExecutionProvider",)
    threads: int | None = None


class OnnxKind:
    """Reads ONNX graph signatures."""

    name = "onnx"
    config_type = OnnxConfig
    suffixes = (".onnx",)
    summary = "ONNX model run by onnxruntime"
    mime_type = "application/x-onnx"
    capabilities = frozenset({TIMELESS, EVALUATED_AT_START, FILE_HASHED})
    libraries = ("onnxruntime",)
    display = Display(
        "ONNX",
        'shape=box, style="rounded,filled", fillcolor="#f3e8ff", color="#7e22ce"',
        ("[[", "]]"),
        "#f3e8ff",
    )
    ros2_defaults: Mapping[tuple[str, str], RoleDefault] = {}

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The entry's pydantic model (:mod:`.spec`), loaded on first use."""
        from fmionnx.kinds.onnx.spec import OnnxSpec

        return OnnxSpec

    def check(
        self, spec: ComponentSpecBase, interface: ComponentInterface
    ) -> tuple[KindProblem, ...]:
        """``units`` names ports of the graph and gives each a unit name (E018)."""
        from fmionnx.kinds.onnx.spec import OnnxSpec  # pydantic: loaded with the entry

        assert isinstance(spec, OnnxSpec)
        return unit_problems(spec.units, interface)

    def validate_model(self, path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
        """The ONNX checker and strict shape inference (loads onnx)."""
        from fmionnx.kinds.onnx.validation import validate_onnx_model

        return validate_onnx_model(path)

    def resolve(self, spec: ComponentSpecBase, interface: ComponentInterface) -> OnnxConfig:
        """Providers and threads as given."""
        from fmionnx.kinds.onnx.spec import OnnxSpec  # pydantic: loaded with the entry

        assert isinstance(spec, OnnxSpec)
        return OnnxConfig(providers=tuple(spec.providers), threads=spec.threads)

    def repeat_problem(self, component: Component) -> str | None:
        """None: an ONNX model has no state, its outputs are a function of its inputs."""
        return None

    def for_workers(self) -> None:
        """Sessions without ``threads`` of their own use one thread (onnxruntime's default pool
        spins a thread per core, taking other cases' cores), and a session serves the model's
        next cases (:mod:`fmionnx.kinds.kept`)."""
        from fmionnx.kinds.onnx.runner import keep_sessions, one_thread_each

        one_thread_each()
        keep_sessions()

    def make_runner(self, component: Component, wiring: Wiring) -> Runner:
        """An :class:`~fmionnx.kinds.onnx.runner.OnnxRunner` (loads onnxruntime only now)."""
        from fmionnx.kinds.onnx.runner import OnnxRunner

        return OnnxRunner(component, dict(wiring.sizes or {}))

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the model's inputs and outputs; the entry's ``units`` name their units."""
        from fmionnx.kinds.onnx.interface import read_onnx_interface
        from fmionnx.kinds.onnx.spec import OnnxSpec  # pydantic: loaded with the entry

        interface = read_onnx_interface(path)
        if isinstance(spec, OnnxSpec) and spec.units:
            interface = with_units(interface, spec.units)
        return interface


ONNX_KIND = OnnxKind()
