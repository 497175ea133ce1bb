"""Code actions: the fixes the compiler's own hints describe, as edits.

* ``did you mean `theta`?`` (an unknown port, component, parameter or key): replace the
  misspelt name, the part of the diagnostic's range closest to the suggestion (inside the
  quotes of a quoted port name; a port suggested for an endpoint is quoted when its name is
  no dotted word, ``q."x y"``);
* ``quote a port name that is not a dotted word: `p."12"[1]``` (E023): write the endpoint so;
* ``quote the endpoint: 'a.y[0]'`` (an index inside a flow collection): quote it;
* a unit mismatch that the compiler cannot convert (E033): write the connection in its long
  form with a ``factor`` and ``offset`` to fill in (a unit without a definition), or with
  ``convert_units: false`` (different quantities, passed as they are);
* a factor that repeats the automatic conversion (W033): drop ``factor``/``offset``, or keep
  them with ``convert_units: false``.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lsprotocol import types

from fmionnx.compile.endpoints import endpoint_text
from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.core.types import PortRef
from fmionnx.lsp.diagnostics import Published
from fmionnx.lsp.positions import value_end
from fmionnx.spec.model import split_connection
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.yaml import parse_yaml

_DID_YOU_MEAN = re.compile(r"did you mean `(?P<name>[^`]+)`\?")
_QUOTE = re.compile(r"quote the endpoint: '(?P<token>.+?)' \(")
_SEGMENT = re.compile(r"[A-Za-z_$][\w$-]*")
#: A quoted port name in an endpoint: its text (group 1) is one name, blanks and dots and all.
_QUOTED_SEGMENT = re.compile(r'\."([^"\n]+)"')
#: E023 on text that names a port only when quoted: what was written and the quoted form.
_NOT_AN_ENDPOINT = re.compile(r"`(?P<written>[^\n]+)` is not an endpoint")
_QUOTE_PORT = re.compile(r"quote a port name that is not a dotted word: `(?P<fixed>[^`]+)`")
#: Keys of a connection's long form, in the order they are written.
_LONG_FORM = ("from", "to", "factor", "offset", "convert_units")


def actions(
    uri: str, path: Path, text: str, published: Sequence[Published], wanted: types.Range
) -> list[types.CodeAction]:
    """The fixes of the diagnostics of ``published`` (in the file ``path``, open as ``uri``)
    whose range meets ``wanted``."""
    lines = text.split("\n")
    found: list[types.CodeAction] = []
    parsed: tuple[Any, SourceMap] | None = None
    for entry in published:
        if entry.source is None or not _meets(entry.lsp.range, wanted):
            continue
        diagnostic, lsp = entry.source, entry.lsp
        edits: list[tuple[str, list[types.TextEdit], bool]] = []
        hint = diagnostic.hint or ""
        rename = _DID_YOU_MEAN.search(hint)
        if rename is not None:
            is_port = diagnostic.code == codes.UNKNOWN_PORT.code
            edit = _replace_closest(lines, lsp.range, rename["name"], quote=is_port)
            if edit is not None:
                edits.append(edit)
        written = _NOT_AN_ENDPOINT.fullmatch(diagnostic.message)
        fixed = _QUOTE_PORT.search(hint)
        if written is not None and fixed is not None:
            edit = _requote(lines, lsp.range, written["written"], fixed["fixed"])
            if edit is not None:
                edits.append(edit)
        quote = _QUOTE.search(hint)
        if quote is not None:
            edit = _quote(lines, lsp.range, quote["token"])
            if edit is not None:
                edits.append(edit)
        if diagnostic.code in (codes.UNIT.code, codes.UNIT_SUSPICIOUS.code):
            if parsed is None:
                sources = SourceMap(path)
                parsed = (parse_yaml(text, path, sources, DiagnosticBag()), sources)
            edits += _unit_fixes(diagnostic, lines, *parsed)
        for title, text_edits, preferred in edits:
            found.append(
                types.CodeAction(
                    title=title,
                    kind=types.CodeActionKind.QuickFix,
                    diagnostics=[lsp],
                    is_preferred=preferred,
                    edit=types.WorkspaceEdit(changes={uri: text_edits}),
                )
            )
    return found


def _meets(a: types.Range, b: types.Range) -> bool:
    def key(p: types.Position) -> tuple[int, int]:
        return (p.line, p.character)

    return key(a.start) <= key(b.end) and key(b.start) <= key(a.end)


def _replace_closest(
    lines: Sequence[str], where: types.Range, name: str, *, quote: bool = False
) -> tuple[str, list[types.TextEdit], bool] | None:
    """Replace the name in ``where`` that is closest to the suggested ``name``.

    A quoted port name is one candidate, replaced inside its quotes (its words are not names
    of their own: replacing one broke the name); ``quote``: ``name`` is a port of an
    endpoint, quoted when it replaces an unquoted name and is no dotted word.
    """
    row = where.start.line
    if row >= len(lines) or where.end.line != row:
        return None
    begin = where.start.character
    segment = lines[row][begin : where.end.character]
    quoted = [(m.start(1), m.end(1)) for m in _QUOTED_SEGMENT.finditer(segment)]
    candidates = quoted + [
        (m.start(), m.end())
        for m in _SEGMENT.finditer(segment)
        if not any(s - 1 <= m.start() < e + 1 for s, e in quoted)
    ]
    best: tuple[float, int, int, str] | None = None
    for start, end in sorted(candidates):
        text = segment[start:end]
        score = difflib.SequenceMatcher(None, text, name).ratio()
        if text != name and (best is None or score >= best[0]):
            best = (score, start, end, text)
    if best is None or best[0] < 0.5:
        return None
    _, start, end, old = best
    new = name
    if quote and (start, end) not in quoted:
        new = endpoint_text(PortRef("_", name)).removeprefix("_.")
    edit = _edit(row, begin + start, begin + end, new)
    return f"Replace `{old}` with `{new}`", [edit], True


def _requote(
    lines: Sequence[str], where: types.Range, written: str, fixed: str
) -> tuple[str, list[types.TextEdit], bool] | None:
    """Replace the endpoint ``written`` where the diagnostic starts with its quoted form."""
    row = where.start.line
    if row >= len(lines) or lines[row].find(written, where.start.character) != (
        where.start.character
    ):
        return None
    start = where.start.character
    return f"Quote the port name: `{fixed}`", [_edit(row, start, start + len(written), fixed)], True


def _quote(
    lines: Sequence[str], where: types.Range, token: str
) -> tuple[str, list[types.TextEdit], bool] | None:
    row = where.start.line
    if row >= len(lines):
        return None
    text = lines[row]
    column = where.start.character
    start = text.find(token)
    while start >= 0 and not start <= column <= start + len(token):
        start = text.find(token, start + 1)
    if start < 0:
        return None
    quoted = "'" + token.replace("'", "''") + "'"
    return f"Quote `{token}`", [_edit(row, start, start + len(token), quoted)], True


def _edit(row: int, start: int, end: int, text: str) -> types.TextEdit:
    return types.TextEdit(
        types.Range(
            types.Position(line=row, character=start), types.Position(line=row, character=end)
        ),
        text,
    )


# -- unit conversions -------------------------------------------------------------------------


def _unit_fixes(
    diagnostic: Diagnostic, lines: Sequence[str], data: Any, sources: SourceMap
) -> list[tuple[str, list[types.TextEdit], bool]]:
    entry = _connection_at(diagnostic, data, sources)
    if entry is None:
        return []
    index, value = entry
    hint = diagnostic.hint or ""
    if diagnostic.code == codes.UNIT.code and "factor" in hint:
        keys = {"factor": 1.0, "offset": 0.0}
        return _long_form(
            index, value, keys, (), lines, sources, "Convert with a factor and offset (long form)"
        )
    if diagnostic.code == codes.UNIT.code and "convert_units" in hint:
        keys = {"convert_units": False}
        title = "Pass the values unconverted (`convert_units: false`)"
        return _long_form(index, value, keys, (), lines, sources, title)
    if diagnostic.code == codes.UNIT_SUSPICIOUS.code and "drop" in hint and isinstance(value, dict):
        drop = _long_form(index, value, {}, ("factor", "offset"), lines, sources,
                          "Drop `factor`/`offset`: fmionnx converts the units")  # fmt: skip
        keep = _long_form(index, value, {"convert_units": False}, (), lines, sources,
                          "Keep only your factor/offset (`convert_units: false`)")  # fmt: skip
        return drop + keep
    return []


def _connection_at(diagnostic: Diagnostic, data: Any, sources: SourceMap) -> tuple[int, Any] | None:
    """The connection entry the diagnostic is about (its span is the entry's start)."""
    span = diagnostic.span
    connections = data.get("connections") if isinstance(data, dict) else None
    if span is None or not isinstance(connections, list):
        return None
    for index, value in enumerate(connections):
        at = sources.spans.get(("connections", index))
        if at is not None and (at.line, at.col) == (span.line, span.col):
            return index, value
    return None


def _long_form(
    index: int,
    value: Any,
    add: dict[str, Any],
    drop: tuple[str, ...],
    lines: Sequence[str],
    sources: SourceMap,
    title: str,
) -> list[tuple[str, list[types.TextEdit], bool]]:
    """The entry rewritten as a flow mapping ``{from: ..., to: ..., ...}`` on its line."""
    if isinstance(value, str):
        ends = split_connection(value)
        if ends is None:
            return []
        keys: dict[str, Any] = {"from": ends[0], "to": ends[1]}
    elif isinstance(value, dict):
        keys = dict(value)
    else:
        return []
    at = sources.spans.get(("connections", index))
    if at is None or at.line < 1 or at.line > len(lines):
        return []
    row, start = at.line - 1, at.col - 1
    text = lines[row]
    one_line = isinstance(value, str) or text[start : start + 1] == "{"
    for key in drop:
        keys.pop(key, None)
    keys.update(add)
    written = "{" + ", ".join(f"{k}: {_scalar(keys[k])}" for k in _ordered(keys)) + "}"
    if one_line:
        end = value_end(text, start)
        return [(title, [_edit(row, start, end, written)], False)]
    return _block_edits(index, keys, add, drop, lines, sources, title)


def _block_edits(
    index: int,
    keys: dict[str, Any],
    add: dict[str, Any],
    drop: tuple[str, ...],
    lines: Sequence[str],
    sources: SourceMap,
    title: str,
) -> list[tuple[str, list[types.TextEdit], bool]]:
    """Keys added after the entry's last line and dropped keys' lines removed (block style)."""
    spans = {k: sources.key_spans.get(("connections", index, k)) for k in _LONG_FORM}
    present = [s for s in spans.values() if s is not None]
    if not present:
        return []
    column = present[0].col - 1
    last = max(s.line for s in present)
    edits = [
        types.TextEdit(
            types.Range(
                types.Position(line=span.line - 1, character=0),
                types.Position(line=span.line, character=0),
            ),
            "",
        )
        for key, span in spans.items()
        if key in drop and span is not None
    ]
    new = [k for k in _ordered(keys) if k in add and spans.get(k) is None]
    if new:
        inserted = "".join(" " * column + f"{k}: {_scalar(keys[k])}\n" for k in new)
        position = types.Position(line=min(last, len(lines)), character=0)
        edits.append(types.TextEdit(types.Range(position, position), inserted))
    for key in (k for k in add if spans.get(k) is not None):
        span = spans[key]
        assert span is not None
        text = lines[span.line - 1]
        colon = text.find(":", span.col - 1)
        end = value_end(
            text, colon + 1 + (len(text[colon + 1 :]) - len(text[colon + 1 :].lstrip()))
        )
        edits.append(_edit(span.line - 1, colon + 1, end, f" {_scalar(keys[key])}"))
    return [(title, edits, False)] if edits else []


def _ordered(keys: dict[str, Any]) -> list[str]:
    known = [k for k in _LONG_FORM if k in keys]
    return known + [k for k in keys if k not in _LONG_FORM]


def _scalar(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        plain = re.fullmatch(r"[A-Za-z_][\w.:$-]*", value) is not None
        return value if plain else "'" + value.replace("'", "''") + "'"
    return repr(value)
