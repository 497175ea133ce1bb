"""The contract every component kind implements, and the interface cache key."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from fmionnx.compile.ir import ComponentInterface
from fmionnx.spec.base import ComponentSpecBase


class ComponentKind(Protocol):
    """One kind of component (``fmu``, ``onnx``, ``mujoco``).

    ``read_interface`` reads the model file's real interface and raises
    :class:`fmionnx.core.errors.ModelError` (with a diagnostics code) when the file is missing,
    unreadable or unsupported. ``spec`` may be None (``fmionnx inspect`` on a bare file); kinds
    whose ports depend on options (MuJoCo camera sizes) then use their defaults. Heavy
    libraries are imported inside methods so that ``validate`` stays fast.
    """

    @property
    def name(self) -> str:
        """Key of the kind in system files (``kind: fmu``)."""
        ...

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The pydantic model of this kind's component entry."""
        ...

    @property
    def suffixes(self) -> tuple[str, ...]:
        """File name endings recognised by ``fmionnx inspect``."""
        ...

    @property
    def summary(self) -> str:
        """One line for help texts."""
        ...

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the interface of the model at ``path``."""
        ...
