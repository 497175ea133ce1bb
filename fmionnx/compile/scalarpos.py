"""Positions inside a YAML string value: offset ``n`` of the text -> ``file:line:col``.

The source map knows where a value starts. An error found at some character of an
expression should point at that character, so the value's text is located in the source
again: a plain or quoted scalar on one line, or a plain scalar folded over several lines
(its lines joined by single spaces). When the source does not show the text that way
(escapes, block scalars, an SSP annotation), the value's own position is the answer.
"""

from __future__ import annotations

from fmionnx.core.diagnostics import Span
from fmionnx.core.sourcetext import source_lines


def position_in_value(value: Span, text: str, offset: int) -> Span:
    """The span of character ``offset`` of ``text``, the string value that starts at ``value``."""
    lines = source_lines(value.file)
    if not value.line or not value.col or not 0 < value.line <= len(lines):
        return value
    first = lines[value.line - 1][value.col - 1 :]
    if first[:1] in ("'", '"'):
        body = first[1:]
        if body.startswith(text) and "\\" not in text and "''" not in text:
            return Span(value.file, value.line, value.col + 1 + offset)
        return value
    return _in_plain(value, lines, text, offset)


def _in_plain(value: Span, lines: tuple[str, ...], text: str, offset: int) -> Span:
    """Offsets of a plain scalar, folded over lines joined by single spaces."""
    line, col = value.line, value.col
    chunk = lines[line - 1][col - 1 :]
    consumed = 0
    while True:
        piece = chunk.rstrip() if consumed == 0 else chunk.strip()
        lead = len(chunk) - len(chunk.lstrip()) if consumed else 0
        rest = text[consumed:]
        if rest.startswith(piece) and (len(piece) == len(rest) or rest[len(piece)] == " "):
            if offset < consumed + len(piece):
                return Span(value.file, line, col + lead + (offset - consumed))
            consumed += len(piece) + 1
        elif rest and piece.startswith(rest):  # the last line, with a comment after the text
            return Span(value.file, line, col + lead + (offset - consumed))
        else:
            return value
        if consumed >= len(text) or line >= len(lines):
            return value
        line, col = line + 1, 1
        chunk = lines[line - 1]
