"""Go to definition: from a name to where its model declares it.

A port goes to its declaration (the ``modelDescription.xml`` line of an FMU variable, the
MuJoCo XML element, the ONNX input or output on the model's page); a component and a model
``path:`` to the model (:mod:`fmionnx.lsp.declarations`); a site to its ``<site>`` element;
``component.expected_path`` to the path file; a study's ``system:`` to the system file.
"""

from __future__ import annotations

from lsprotocol import types

from fmionnx.compile.expected_path import expected_path_file
from fmionnx.lsp.analysis import DocumentKind
from fmionnx.lsp.declarations import Place, model_place, named_element, port_place
from fmionnx.lsp.diagnostics import uri_of
from fmionnx.lsp.outline import ComponentOutline, Outline
from fmionnx.lsp.references import Reference, components_of, reference_at
from fmionnx.lsp.yamlcontext import cursor_at


def definition(
    text: str, line: int, column: int, kind: DocumentKind, outline: Outline | None
) -> list[types.Location]:
    """Where the name at 0-based ``line``/``column`` is defined (empty when nowhere known)."""
    if kind not in (DocumentKind.SYSTEM, DocumentKind.STUDY) or outline is None:
        return []
    place = _path_value(text, line, column, kind, outline)
    if place is None:
        reference = reference_at(text, line, column, outline)
        place = _place(reference) if reference is not None else None
    if place is None:
        return []
    row = max(place.line - 1, 0)
    position = types.Position(line=row, character=0)
    return [types.Location(uri_of(place.file), types.Range(position, position))]


def _place(reference: Reference) -> Place | None:
    component = reference.component
    if component is None:
        return None
    if reference.what == "port" and reference.port is not None and component.interface:
        return port_place(component.interface, reference.port)
    if reference.what == "component":
        return _component_place(component)
    if reference.what == "site" and component.model is not None:
        return named_element(component.model, reference.name, ("site",))
    if reference.what == "expected_path" and component.model is not None:
        file = expected_path_file(component.model)
        return Place(file, 1) if file.is_file() else None
    if reference.what == "map" and component.model is not None:
        return Place(component.model, 1)
    return None


def _component_place(component: ComponentOutline) -> Place | None:
    if component.interface is not None:
        return model_place(component.interface)
    if component.model is not None and component.model.is_file():
        return Place(component.model, 1)
    return None


def _path_value(
    text: str, line: int, column: int, kind: DocumentKind, outline: Outline
) -> Place | None:
    """A component's ``path:`` value goes to its model; a study's ``system:`` to the system."""
    where = cursor_at(text, line, column)
    if where.role != "value":
        return None
    if kind is DocumentKind.STUDY and where.path == ("system",):
        system = outline.data.get("system") if isinstance(outline.data, dict) else None
        if isinstance(system, str):
            target = outline.path.parent / system
            return Place(target, 1) if target.is_file() else None
        return None
    if len(where.path) == 3 and where.path[0] == "components" and where.path[2] == "path":
        component = components_of(outline).get(where.path[1])
        if component is not None:
            return _component_place(component)
    return None
