"""Rename a component across its system file.

A component's name is written as its key under ``components:`` and wherever something of it
is named: connections (one-line and long form), ``record``, ``plots``, check expressions,
system ``inputs``, and the ``ros2`` section (node keys, topic and QoS keys). Each of those
values is searched for dotted names whose component, split as the compiler splits endpoints
(the longest component name that prefixes them), is the one renamed; positions inside a value
come from the compiler's own mapping (:func:`fmionnx.compile.scalarpos.position_in_value`),
so quoted and folded values are edited where the name really is. A quoted port
(``p."input.1"``) belongs to the component written before its quotes and is kept as it is:
the words inside the quotes are the port's name, never a component's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lsprotocol import types

from fmionnx.compile.scalarpos import position_in_value
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.sourcetext import editing
from fmionnx.lsp.yamlcontext import NAME, cursor_at, name_at, quoted_port
from fmionnx.spec.model import DOTTED_NAME
from fmionnx.spec.sourcemap import KeyPath, SourceMap
from fmionnx.spec.yaml import parse_yaml


class RenameError(ValueError):
    """A rename that cannot be done: the message says why (shown to the user)."""


@dataclass(frozen=True, slots=True)
class _File:
    data: dict[str, Any]
    sources: SourceMap
    components: tuple[str, ...]


def _parse(path: Path, text: str) -> _File | None:
    sources = SourceMap(path)
    data = parse_yaml(text, path, sources, DiagnosticBag())
    if not isinstance(data, dict) or not isinstance(data.get("components"), dict):
        return None
    return _File(data, sources, tuple(str(n) for n in data["components"]))


def component_at(path: Path, text: str, line: int, column: int) -> tuple[str, types.Range] | None:
    """The component whose name is under the cursor, and the range of that name."""
    parsed = _parse(path, text)
    lines = text.split("\n")
    if parsed is None or line >= len(lines):
        return None
    found = name_at(lines[line], column)
    if found is None:
        return None
    name, start = found
    owner = _owner(name, parsed.components)
    if owner is None:
        return None
    where = cursor_at(text, line, start)
    if where.path[:1] == ("components",) and len(where.path) > 1:
        return None  # a key inside an entry (a parameter), not a component
    if column > start + len(owner):
        return None  # the cursor is on the port, not on the component
    span = types.Range(
        types.Position(line=line, character=start),
        types.Position(line=line, character=start + len(owner)),
    )
    return owner, span


def _owner(name: str, components: tuple[str, ...]) -> str | None:
    """The component a dotted name belongs to (the longest prefix), or the name itself; a
    quoted port's, the component written before the quotes."""
    quoted = quoted_port(re.sub(r"\[[^\]]*\]$", "", name))
    if quoted is not None:
        return quoted[0] if quoted[0] in components else None
    if name in components:
        return name
    best = ""
    for component in components:
        if name.startswith(component + ".") and len(component) > len(best):
            best = component
    return best or None


def rename(
    uri: str, path: Path, text: str, line: int, column: int, new_name: str
) -> types.WorkspaceEdit:
    """The edits renaming the component under the cursor of ``path`` (open as ``uri``) to
    ``new_name`` (RenameError when it cannot be done)."""
    found = component_at(path, text, line, column)
    parsed = _parse(path, text)
    if found is None or parsed is None:
        msg = "place the cursor on a component's name to rename it"
        raise RenameError(msg)
    old = found[0]
    if not DOTTED_NAME.fullmatch(new_name):
        msg = (
            f"`{new_name}` is not a component name: it starts with a letter or `_` and has "
            "only letters, digits, `_`, `-` (and `.` between parts)"
        )
        raise RenameError(msg)
    if new_name in parsed.components and new_name != old:
        msg = f"there is already a component `{new_name}`"
        raise RenameError(msg)
    lines = text.split("\n")
    edits: dict[tuple[int, int], types.TextEdit] = {}
    with editing({path: text}):
        for span, length in _occurrences(parsed, old, lines):
            row, col = span.line - 1, span.col - 1
            if 0 <= row < len(lines) and lines[row][col : col + length] == old:
                edits[(row, col)] = types.TextEdit(
                    types.Range(
                        types.Position(line=row, character=col),
                        types.Position(line=row, character=col + length),
                    ),
                    new_name,
                )
    ordered = [edits[k] for k in sorted(edits)]
    return types.WorkspaceEdit(changes={uri: ordered})


def _occurrences(parsed: _File, old: str, lines: list[str]) -> Iterator[tuple[Span, int]]:
    sources, data = parsed.sources, parsed.data
    key = sources.key_spans.get(("components", old))
    if key is not None:
        yield _key_text(key, lines), len(old)
    for path, value in _referencing_values(data):
        span = sources.spans.get(path)
        if span is None or not isinstance(value, str):
            continue
        for offset in _offsets(value, old, parsed.components):
            yield position_in_value(span, value, offset), len(old)
    ros2 = data.get("ros2")
    if isinstance(ros2, dict):
        for section in ("nodes", "topics", "qos"):
            entries = ros2.get(section)
            if not isinstance(entries, dict):
                continue
            for name in entries:
                key = sources.key_spans.get(("ros2", section, name))
                if key is None:
                    continue
                for offset in _offsets(str(name), old, parsed.components):
                    at = _key_text(key, lines)
                    yield Span(at.file, at.line, at.col + offset), len(old)


def _key_text(span: Span, lines: list[str]) -> Span:
    """The span of a key's text (after its opening quote, when quoted)."""
    row = span.line - 1
    if 0 <= row < len(lines) and lines[row][span.col - 1 : span.col] in ("'", '"'):
        return Span(span.file, span.line, span.col + 1)
    return span


def _offsets(value: str, old: str, components: tuple[str, ...]) -> Iterator[int]:
    for match in NAME.finditer(value):
        if _owner(match.group(0), components) == old:
            yield match.start()


def _referencing_values(data: dict[str, Any]) -> Iterator[tuple[KeyPath, Any]]:
    """Every value of the file that names components, with its key path."""
    for index, entry in enumerate(_list(data.get("connections"))):
        if isinstance(entry, dict):
            for key in ("from", "to"):
                yield ("connections", index, key), entry.get(key)
        else:
            yield ("connections", index), entry
    for index, entry in enumerate(_list(data.get("record"))):
        yield ("record", index), entry
    for index, plot in enumerate(_list(data.get("plots"))):
        if isinstance(plot, dict):
            for axis in ("xy", "y"):
                for inner, signal in enumerate(_list(plot.get(axis))):
                    yield ("plots", index, axis, inner), signal
            yield ("plots", index, "over"), plot.get("over")
    for index, check in enumerate(_list(data.get("checks"))):
        if isinstance(check, dict):
            yield ("checks", index, "expect"), check.get("expect")
    inputs = data.get("inputs")
    if isinstance(inputs, dict):
        for name, entry in inputs.items():
            targets = entry.get("to") if isinstance(entry, dict) else None
            for index, target in enumerate(_list(targets)):
                if isinstance(target, dict):
                    yield ("inputs", name, "to", index, "to"), target.get("to")
                else:
                    yield ("inputs", name, "to", index), target


def _list(value: Any) -> list[Any]:
    return value if isinstance(value, list) else []
