"""fmionnx spans (a 1-based line and column where something starts) as LSP ranges.

``fmionnx validate`` points at where a problem starts; an editor underlines a range. The range
starts exactly at the diagnostic's line and column and ends where the thing there ends:

* a problem inside a value (an endpoint of a connection, a name in a check expression, a
  syntax error): the token there, a dotted name with its index such as ``odometry.thta`` or
  ``world.base_quat[7]``, its port quoted or not (``q."x  y"``), or a quoted string;
* a key (the token is followed by ``:``): the key;
* any other problem is about the value that starts there (a connection ``a.y -> b.u`` with a
  unit mismatch, a period, a flow mapping): to the end of that scalar or bracket on its line;
* a span of a whole file (line 0): the first line; of a whole line (column 0): its text.

Positions here count characters (code points); the server converts them to the client's
encoding (UTF-16 by default) against the document's text.
"""

from __future__ import annotations

from collections.abc import Sequence

from lsprotocol import types

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span

#: Codes whose span is a position inside a value (an endpoint, a name in an expression, a
#: syntax error's character): the range is the token there, never the whole value that
#: starts at the same column.
INSIDE_VALUE_CODES = frozenset(
    entry.code
    for entry in (
        codes.SYNTAX, codes.UNKNOWN_COMPONENT, codes.UNKNOWN_PORT, codes.BAD_INDEX,
        codes.BAD_ENDPOINT, codes.UNSUPPORTED_VARIABLE, codes.PLOT, codes.PLOT_SIGNAL,
        codes.CHECK_SYNTAX, codes.CHECK_SIGNAL, codes.CHECK_REFERENCE, codes.CHECK_MEANING,
    )
)  # fmt: skip


def token_end(text: str, start: int) -> int:
    """The end of the token that starts at ``start`` of the line ``text``."""
    if start >= len(text):
        return start
    first = text[start]
    if first in "'\"":
        return _quoted_end(text, start)
    depth = 0
    index = start
    while index < len(text):
        char = text[index]
        closing = text.find('"', index + 1) if char == '"' and text[index - 1] == "." else -1
        if closing > index + 1:  # a quoted port name (`q."x  y"`): its blanks are the name's
            index = closing + 1
            continue
        ends_key = char == ":" and (index + 1 == len(text) or text[index + 1].isspace())
        if char.isspace() or char in ",{}()" or ends_key:
            break
        if char == "[":
            depth += 1
        elif char == "]":
            if depth == 0:
                break
            depth -= 1
        index += 1
    return index if index > start else start + 1


def _quoted_end(text: str, start: int) -> int:
    quote = text[start]
    index = start + 1
    while index < len(text):
        if text[index] == quote:
            if quote == "'" and text[index + 1 : index + 2] == "'":
                index += 2  # '' is a quote inside a single-quoted scalar
                continue
            return index + 1
        if quote == '"' and text[index] == "\\":
            index += 1
        index += 1
    return len(text)


def value_end(text: str, start: int) -> int:
    """The end of the YAML value that starts at ``start`` of the line ``text`` (that line's
    part of it): a quoted scalar, a bracketed collection, or a plain scalar up to a comment,
    or inside brackets up to the next ``,``/``]``/``}``."""
    if start >= len(text):
        return start
    first = text[start]
    if first in "'\"":
        return _quoted_end(text, start)
    if first in "[{":
        return _bracket_end(text, start)
    inside_flow = _open_brackets(text[:start]) > 0
    index = start
    while index < len(text):
        char = text[index]
        if inside_flow and char in ",]}":
            break
        if char == "#" and text[index - 1].isspace():
            break
        index += 1
    return len(text[:index].rstrip()) if index > start else start + 1


def _bracket_end(text: str, start: int) -> int:
    depth = 0
    quote: str | None = None
    for index in range(start, len(text)):
        char = text[index]
        if quote is not None:
            if char == quote:
                quote = None
        elif char in "'\"":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
            if depth == 0:
                return index + 1
    return len(text.rstrip())


def _open_brackets(text: str) -> int:
    depth = 0
    quote: str | None = None
    for char in text:
        if quote is not None:
            if char == quote:
                quote = None
        elif char in "'\"":
            quote = char
        elif char in "[{":
            depth += 1
        elif char in "]}":
            depth = max(0, depth - 1)
    return depth


def line_range(lines: Sequence[str], line: int) -> types.Range:
    """The text of 0-based ``line`` (from its first non-blank character)."""
    text = lines[line] if 0 <= line < len(lines) else ""
    begin = len(text) - len(text.lstrip())
    return types.Range(
        types.Position(line=max(line, 0), character=begin),
        types.Position(line=max(line, 0), character=len(text.rstrip())),
    )


def span_range(span: Span | None, lines: Sequence[str], *, code: str = "") -> types.Range:
    """The range of a diagnostic's ``span`` in a file whose lines are ``lines``; ``code``
    says whether the problem is a point inside a value (:data:`INSIDE_VALUE_CODES`)."""
    if span is None or span.line <= 0:
        return line_range(lines, 0)
    row = span.line - 1
    if span.col <= 0:
        return line_range(lines, row)
    text = lines[row] if row < len(lines) else ""
    start = min(span.col - 1, len(text))
    end = token_end(text, start)
    if code not in INSIDE_VALUE_CODES and not _is_key(text, end):
        end = value_end(text, start)
    return types.Range(
        types.Position(line=row, character=start),
        types.Position(line=row, character=max(start, min(end, len(text)))),
    )


def _is_key(text: str, end: int) -> bool:
    """Whether the token ending at ``end`` is a mapping key (``:`` and a blank follow)."""
    rest = text[end:].lstrip(" ")
    return rest.startswith(":") and (len(rest) == 1 or rest[1] in " \t")
