"""What an editor needs to know about a file besides its diagnostics: its components and their
real interfaces.

The compiler (``fmionnx.api.compile_system``) gives diagnostics and, when there are none, a
compiled system; but completion and hover are needed most while a file has errors. So the
outline is read on its own, leniently: the YAML is loaded as plain data (within the front
end's resource limits, by ruamel's C safe loader: a few milliseconds, where the parse that
keeps every position takes several times as long, on every keystroke), each component entry
is checked alone against its kind's model (a mistake in one entry leaves the others usable),
and each model's interface is read by :func:`fmionnx.compile.resolve.read_interface`, the
compiler's own reader with its per-process cache: a model whose file did not change is not
read again. Positions are not kept here: the features that edit the file (fixes, rename)
parse the text they edit with the front end itself.
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
from fmionnx.spec.limits import check_limits
from fmionnx.spec.sourcemap import SourceMap

#: Keys kept when an entry is checked again without its faulty keys: what the interface needs.
_INTERFACE_KEYS = ("kind", "path", "cameras", "units", "interface", "outputs")


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
    """A system or study file: its plain data and components.

    ``data`` is the YAML as plain values (None when it does not load, and for an SSD). For a
    study, ``system`` is the outline of the system file it varies.
    """

    path: Path
    data: Any
    components: Mapping[str, ComponentOutline] = field(default_factory=dict)
    system: Outline | None = None


def plain_data(path: Path, text: str) -> Any:
    """The YAML text as plain data, or None when it is over a resource limit or does not
    load (the compiler says why)."""
    if not check_limits(text, path, DiagnosticBag()):
        return None
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        return YAML(typ="safe").load(text)
    except (YAMLError, TypeError, ValueError, AttributeError, KeyError, IndexError):
        return None


def outline_yaml(path: Path, text: str, data: Any = None) -> Outline:
    """The outline of a YAML system or study file whose text is ``text`` (``data``: that text
    already loaded by :func:`plain_data`)."""
    if data is None:
        data = plain_data(path, text)
    return Outline(path, data, _components(path, data))


def outline_loaded(path: Path, components: Mapping[str, ComponentSpecBase]) -> Outline:
    """The outline of a system a front end loaded (an SSD): its entries are checked already."""
    return Outline(path, None, {name: _read(name, spec, path) for name, spec in components.items()})


def _components(path: Path, data: Any) -> dict[str, ComponentOutline]:
    if not isinstance(data, dict) or not isinstance(data.get("components"), dict):
        return {}
    found: dict[str, ComponentOutline] = {}
    for key, entry in data["components"].items():
        name = str(key)
        spec = _entry_spec(entry)
        if spec is None:
            kind = entry.get("kind") if isinstance(entry, dict) else None
            found[name] = ComponentOutline(
                name, kind if isinstance(kind, str) else None, None, None
            )
            continue
        found[name] = _read(name, spec, path)
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


def _read(name: str, spec: ComponentSpecBase, path: Path) -> ComponentOutline:
    # The compiler's reader; the diagnostics it makes are the compiler's too, not wanted here.
    interface = read_interface(name, spec, path, SourceMap(path), DiagnosticBag())
    return ComponentOutline(name, spec.kind, entry_path(path, spec), interface, spec)
