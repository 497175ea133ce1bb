"""Completion, hover and definitions in an SSD file, from its components' real interfaces.

An SSD names components and connectors in attributes: ``<ssd:Connection startElement="integ"
startConnector="x" endElement="gain" endConnector="u"/>``, ``<ssd:Component name="gain"
source="resources/gain.fmu">``. The attribute under the cursor and the other attributes of its
element are read from the text around the cursor (an element being typed does not parse yet):

* ``startElement``/``endElement`` complete to component names, ``startConnector`` to the
  start element's outputs, ``endConnector`` to the end element's inputs;
* hover and definition on a connector are the port's, on an element name or a component's
  ``name``/``source`` the component's (its model).

Names are the SSP front end's: a component of a nested system is ``sub.comp``; a connection
inside that system names ``comp``, which is looked up as written, then under each prefix.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from lsprotocol import types

from fmionnx.core.types import Causality, Port
from fmionnx.lsp.completion import port_detail
from fmionnx.lsp.declarations import Place, model_place, port_place
from fmionnx.lsp.hover import component_text, port_text
from fmionnx.lsp.outline import ComponentOutline, Outline

_ATTRIBUTE = re.compile(r'(?P<name>[\w:.-]+)\s*=\s*(?P<quote>["\'])(?P<value>.*?)(?P=quote)', re.S)
_PARTIAL = re.compile(r'(?P<name>[\w:.-]+)\s*=\s*(?P<quote>["\'])(?P<value>[^"\']*)$')
_K = types.CompletionItemKind


@dataclass(frozen=True, slots=True)
class _At:
    """The attribute the cursor is in: its name, its value up to the cursor, where the value
    starts and ends on the line, and the other attributes of its element."""

    name: str
    typed: str
    start: int
    end: int
    others: dict[str, str]


def _attribute_at(text: str, line: int, column: int) -> _At | None:
    lines = text.split("\n")
    if line >= len(lines):
        return None
    offset = sum(len(row) + 1 for row in lines[:line]) + min(column, len(lines[line]))
    opening = text.rfind("<", 0, offset)
    if opening < 0 or text.rfind(">", 0, offset) > opening:
        return None
    closing = text.find(">", offset)
    element = text[opening : closing if closing >= 0 else len(text)]
    others = {m["name"].split(":")[-1]: m["value"] for m in _ATTRIBUTE.finditer(element)}
    before = text[opening:offset]
    partial = _PARTIAL.search(before)
    if partial is None:
        return None
    typed = partial["value"]
    row = lines[line]
    start = min(column, len(row)) - len(typed)
    end = start
    while end < len(row) and row[end] not in "\"'":
        end += 1
    return _At(partial["name"].split(":")[-1], typed, start, end, others)


def _component(outline: Outline, name: str | None) -> ComponentOutline | None:
    if not name:
        return None
    if name in outline.components:
        return outline.components[name]
    for full, component in outline.components.items():
        if full.endswith("." + name):
            return component
    return None


def _range(line: int, start: int, end: int) -> types.Range:
    return types.Range(
        types.Position(line=line, character=start), types.Position(line=line, character=end)
    )


def complete_ssd(
    text: str, line: int, column: int, outline: Outline | None
) -> list[types.CompletionItem]:
    """Completion in an attribute value of an SSD element."""
    at = _attribute_at(text, line, column)
    if at is None or outline is None:
        return []
    edit = _range(line, at.start, at.end)

    def item(label: str, kind: types.CompletionItemKind, detail: str) -> types.CompletionItem:
        return types.CompletionItem(
            label=label, kind=kind, detail=detail, text_edit=types.TextEdit(edit, label)
        )

    if at.name in ("startElement", "endElement"):
        return [
            item(
                name.rpartition(".")[2],
                _K.Module,
                f"{c.kind or '?'} {c.model.name if c.model else ''}".strip(),
            )
            for name, c in outline.components.items()
        ]
    side = {
        "startConnector": ("startElement", Causality.OUTPUT),
        "endConnector": ("endElement", Causality.INPUT),
    }
    if at.name in side:
        element, causality = side[at.name]
        component = _component(outline, at.others.get(element))
        if component is None or component.interface is None:
            return []
        return [
            item(
                port.name,
                _K.Field if causality is Causality.OUTPUT else _K.Property,
                port_detail(port),
            )
            for port in component.interface.with_causality(causality)
        ]
    return []


_Target = tuple[ComponentOutline, Port | None, types.Range]


def _target(text: str, line: int, column: int, outline: Outline | None) -> _Target | None:
    """What the attribute under the cursor names: (component, port or None, range)."""
    at = _attribute_at(text, line, column)
    if at is None or outline is None:
        return None
    span = _range(line, at.start, at.end)
    if at.name in ("startConnector", "endConnector"):
        element = at.others.get("startElement" if at.name == "startConnector" else "endElement")
        component = _component(outline, element)
        if component is None or component.interface is None:
            return None
        port = component.interface.port(at.others.get(at.name, ""))
        return (component, port, span) if port is not None else None
    if at.name in ("startElement", "endElement"):
        component = _component(outline, at.others.get(at.name))
        return (component, None, span) if component is not None else None
    if at.name in ("name", "source"):
        component = _component(outline, at.others.get("name"))
        return (component, None, span) if component is not None else None
    return None


def hover_ssd(
    text: str, line: int, column: int, outline: Outline | None
) -> tuple[str, types.Range] | None:
    """Markdown about the connector or component under the cursor, and its range."""
    found = _target(text, line, column, outline)
    if found is None:
        return None
    component, port, span = found
    return (port_text(component, port) if port is not None else component_text(component)), span


def definition_ssd(text: str, line: int, column: int, outline: Outline | None) -> Place | None:
    """Where the connector or component under the cursor is declared in its model."""
    found = _target(text, line, column, outline)
    if found is None:
        return None
    component, port, _ = found
    if component.interface is None:
        return None
    if port is not None:
        return port_place(component.interface, port)
    return model_place(component.interface)
