"""Hover: what a name stands for, read from the model it names.

* a port: causality, element type, shape, unit, description, start value, and where it is
  declared (``ReadOdometry.fmu/modelDescription.xml:57``);
* a component: its kind, model file, FMI version (for an FMU) and interface counts;
* a site, an expected path, a function of the checks language, a key of the file format;
* a diagnostic's code (under the cursor's diagnostic, or a code such as ``E021`` written in
  the file): its name and explanation from the code table.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from lsprotocol import types
from pydantic import BaseModel

from fmionnx.compile.endpoints import endpoint_text
from fmionnx.compile.expected_path import expected_path_file
from fmionnx.core.diagnostics import CODES
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Causality, Port, PortRef
from fmionnx.kinds.base import SiteSource
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.lsp.analysis import DocumentKind
from fmionnx.lsp.outline import ComponentOutline, Outline
from fmionnx.lsp.references import Reference, reference_at
from fmionnx.lsp.schema import key_description
from fmionnx.lsp.yamlcontext import cursor_at, name_at
from fmionnx.spec.model import SystemSpec
from fmionnx.spec.study import StudySpec

_INTERFACE_TYPES = {"cs": "co-simulation", "me": "model exchange", "se": "scheduled execution"}


def hover(
    text: str,
    line: int,
    column: int,
    kind: DocumentKind,
    outline: Outline | None,
    codes: Sequence[str] = (),
) -> types.Hover | None:
    """The hover at 0-based ``line``/``column``; ``codes`` are the codes of the diagnostics
    whose range contains the position."""
    parts: list[str] = []
    span: types.Range | None = None
    if kind in (DocumentKind.SYSTEM, DocumentKind.STUDY):
        reference = reference_at(text, line, column, outline)
        if reference is not None:
            parts.append(describe(reference))
            span = _range(reference)
        else:
            about_key = _key(text, line, column, kind, outline)
            if about_key is not None:
                parts.append(about_key)
    lines = text.split("\n")
    written = name_at(lines[line], column) if line < len(lines) else None
    if written is not None and written[0] in CODES and written[0] not in codes:
        codes = (*codes, written[0])
    parts += [code_text(code) for code in dict.fromkeys(codes)]
    parts = [p for p in parts if p]
    if not parts:
        return None
    return types.Hover(
        types.MarkupContent(types.MarkupKind.Markdown, "\n\n---\n\n".join(parts)), span
    )


def _range(reference: Reference) -> types.Range:
    return types.Range(
        types.Position(line=reference.line, character=reference.start),
        types.Position(line=reference.line, character=reference.end),
    )


def code_text(code: str) -> str:
    """``**E021** `unknown-port` (error, endpoint): A connection names a port ...``."""
    entry = CODES.get(code)
    if entry is None:
        return ""
    return (
        f"**{entry.code}** `{entry.name}` ({entry.severity.label}, {entry.category}): "
        f"{entry.description}"
    )


def describe(reference: Reference) -> str:
    """Markdown about what ``reference`` names."""
    component = reference.component
    if reference.what == "port" and reference.port is not None and component is not None:
        return port_text(component, reference.port, endpoint=True)
    if reference.what == "component" and component is not None:
        return component_text(component)
    if reference.what == "site" and component is not None:
        return _site_text(component, reference.name)
    if reference.what == "expected_path" and component is not None and component.model:
        file = expected_path_file(component.model)
        there = "" if file.is_file() else " (missing)"
        return (
            f"**{reference.name}**: the expected path of `{component.name}`, `{file.name}`{there}"
        )
    if reference.what == "map" and component is not None:
        return f"**{reference.name}**: the fixed landmarks of `{component.name}`'s scene"
    if reference.what == "function":
        return f"**{reference.name}** — `{reference.detail}` (checks language)"
    return ""


def port_text(component: ComponentOutline, port: Port, *, endpoint: bool = False) -> str:
    """A port's type, shape, unit, description, start value and declaration. ``endpoint``:
    named as a system file's endpoint writes it (``p."input.1"``), so that it can be copied;
    else as the model names it (an SSD's connector)."""
    shape = port.shape_text()
    unit = f", unit `{port.unit}`" if port.unit else ", no unit"
    ref = PortRef(component.name, port.name)
    named = endpoint_text(ref) if endpoint else str(ref)
    lines = [f"**{named}** — {port.causality.value} `{port.dtype.value}` {shape}{unit}"]
    if port.description:
        lines.append(port.description)
    if port.start is not None:
        shown = ", ".join(str(v) for v in port.start[:8]) + (" ..." if len(port.start) > 8 else "")
        lines.append(f"start: `{shown}`")
    if port.variability:
        lines.append(f"variability: {port.variability}")
    declared = _declared(component, port)
    if declared:
        lines.append(f"declared in `{declared}`")
    return "\n\n".join(lines)


def _declared(component: ComponentOutline, port: Port) -> str:
    if port.origin is None:
        return component.model.name if component.model is not None else ""
    return str(port.origin)


def component_text(component: ComponentOutline) -> str:
    """A component's kind, model file, FMI version and interface counts."""
    kind = component.kind or "?"
    lines = [f"**{component.name}** — {kind} component"]
    if component.spec is not None and component.spec.path:
        lines.append(f"model: `{component.spec.path}`")
    interface = component.interface
    if interface is None:
        lines.append("its interface could not be read (see the diagnostics)")
        return "\n\n".join(lines)
    version = interface.fact("fmiVersion")
    if version is not None:
        offered = [
            _INTERFACE_TYPES.get(t, t) for t in (interface.fact("interfaceTypes") or "").split(",")
        ]
        name = interface.fact("modelName")
        named = f" `{name}`" if name else ""
        lines.append(
            f"FMI {version}{named}, {', '.join(o for o in offered if o) or 'no interface'}"
        )
    elif interface.fact("opset") is not None:
        lines.append(f"opset {interface.fact('opset')}")
    counts = Counter(p.causality for p in interface.ports)
    shown = [
        f"{counts[c]} {label}"
        for c, label in (
            (Causality.INPUT, "inputs"),
            (Causality.OUTPUT, "outputs"),
            (Causality.PARAMETER, "parameters"),
            (Causality.STRUCTURAL_PARAMETER, "structural parameters"),
            (Causality.CALCULATED_PARAMETER, "calculated parameters"),
            (Causality.LOCAL, "locals"),
        )
        if counts[c] or c in (Causality.INPUT, Causality.OUTPUT, Causality.PARAMETER)
    ]
    lines.append(", ".join(shown))
    summary = COMPONENT_KINDS[kind].summary if kind in COMPONENT_KINDS else ""
    if summary:
        lines.append(f"_{summary}_")
    return "\n\n".join(lines)


def _site_text(component: ComponentOutline, name: str) -> str:
    kind = COMPONENT_KINDS.get(component.kind or "")
    if not isinstance(kind, SiteSource) or component.model is None:
        return ""
    try:
        site = kind.sites(component.model).get(name)
    except (ModelError, OSError):
        return ""
    if site is None:
        return f"**{component.name}.site.{name}** — no such site in `{component.model.name}`"
    where = ", ".join(f"{v:g}" for v in site.position)
    moving = f"; it moves with body `{site.moves_with}`" if site.moves_with else ""
    return f"**{component.name}.site.{name}** — a site of `{component.model.name}` at ({where}) m{moving}"


def _key(
    text: str, line: int, column: int, kind: DocumentKind, outline: Outline | None
) -> str | None:
    """The description of the format key under the cursor."""
    lines = text.split("\n")
    found = name_at(lines[line], column) if line < len(lines) else None
    if found is None:
        return None
    name, start = found
    rest = lines[line][start + len(name) :]
    if not rest.lstrip().startswith(":"):
        return None
    where = cursor_at(text, line, start)
    root: type[BaseModel] = StudySpec if kind is DocumentKind.STUDY else SystemSpec
    components = outline.components if outline is not None else {}

    def kind_of(component: str) -> str | None:
        found_component = components.get(component)
        return found_component.kind if found_component is not None else None

    description = key_description(root, where.path, name, kind_of)
    if description is None:
        return None
    return f"**{name}**" + (f" — {description}" if description else "")
