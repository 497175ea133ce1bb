"""What an editor needs to know about a file besides its diagnostics: its components, their
real interfaces and where every key and value is.

The compiler (``fmionnx.api.compile_system``) gives diagnostics and, when there are none, a
compiled system; but completion and hover are needed most while a file has errors. So the
outline is read on its own, leniently: the YAML is parsed by the system-file front end
(positions in a :class:`~fmionnx.spec.sourcemap.SourceMap`), each component entry is checked
alone against its kind's model (a mistake in one entry leaves the others usable), and each
model's interface is read by :func:`fmionnx.compile.resolve.read_interface`, the compiler's own
reader with its per-process cache: a model whose file did not change is not read again.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from fmionnx.compile.resolve import entry_path, read_interface
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.yaml import parse_yaml

#: Keys kept when an entry is checked again without its faulty keys: what the interface needs.
_INTERFACE_KEYS = ("kind", "path", "cameras", "units", "interface")


@dataclass(frozen=True, slots=True)
class ComponentOutline:
    """One component entry: its kind and model file, and the interface when it could be read."""

    name: str
    kind: str | None
    model: Path | None
    interface: ComponentInterface | None
    spec: ComponentSpecBase | None = None


@dataclass(frozen=True)
class Outline:
    """A parsed system or study file: its plain data, positions and components.

    ``data`` is the YAML as plain values (None when it does not parse). For a study,
    ``system`` is the outline of the system file it varies.
    """

    path: Path
    data: Any
    sources: SourceMap
    components: Mapping[str, ComponentOutline] = field(default_factory=dict)
    system: Outline | None = None

    @property
    def interfaces(self) -> dict[str, ComponentInterface | None]:
        """Interface per component name (None where it could not be read)."""
        return {name: c.interface for name, c in self.components.items()}


def outline_yaml(path: Path, text: str) -> Outline:
    """The outline of a YAML system or study file whose text is ``text``."""
    sources = SourceMap(path)
    data = parse_yaml(text, path, sources, DiagnosticBag())
    return Outline(path, data, sources, _components(path, data, sources))


def outline_loaded(
    path: Path, components: Mapping[str, ComponentSpecBase], sources: SourceMap
) -> Outline:
    """The outline of a system a front end loaded (an SSD): its specs are already checked."""
    found = {name: _read(name, spec, path, sources) for name, spec in components.items()}
    return Outline(path, None, sources, found)


def _components(path: Path, data: Any, sources: SourceMap) -> dict[str, ComponentOutline]:
    if not isinstance(data, dict) or not isinstance(data.get("components"), dict):
        return {}
    found: dict[str, ComponentOutline] = {}
    for name, entry in data["components"].items():
        spec = _entry_spec(entry)
        if spec is None:
            kind = entry.get("kind") if isinstance(entry, dict) else None
            found[name] = ComponentOutline(
                name, kind if isinstance(kind, str) else None, None, None
            )
            continue
        found[name] = _read(name, spec, path, sources)
    return found


def _entry_spec(entry: Any) -> ComponentSpecBase | None:
    """The entry checked by its kind's model; with a mistake elsewhere in it, the keys that
    decide the interface alone; None when even those do not check."""
    if not isinstance(entry, dict):
        return None
    kind = COMPONENT_KINDS.get(str(entry.get("kind")))
    if kind is None:
        return None
    model: type[ComponentSpecBase] = kind.spec_model
    for candidate in (entry, {k: v for k, v in entry.items() if k in _INTERFACE_KEYS}):
        try:
            return model.model_validate(candidate)
        except ValidationError:
            continue
    return None


def _read(name: str, spec: ComponentSpecBase, path: Path, sources: SourceMap) -> ComponentOutline:
    model = entry_path(path, spec)
    interface = read_interface(name, spec, path, sources, DiagnosticBag())
    return ComponentOutline(name, spec.kind, model, interface, spec)
