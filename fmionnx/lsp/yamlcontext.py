"""Where the cursor is in a YAML file that is being typed: the key path and the text so far.

Completion is asked for while a file is half-written, so it cannot wait for the YAML to
parse: a line ``  - detector.`` is not yet what the file will hold. This module reads the
structure around the cursor from indentation (the block style system files are written in)
and from the brackets on the cursor's own line (the flow style of short entries, such as
``parameters: {turnRate: 0.8, cr``), never from a parse of the whole file.

A path is made of mapping keys and :data:`ITEM` for an entry of a list:
``("components", "tracker", "parameters")``, ``("connections", ITEM)``,
``("plots", ITEM, "xy", ITEM)``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

#: A list entry in a path.
ITEM = "[]"

#: ``key:`` at the start of a line's content: a plain key (no `#`, no `: ` inside) or a
#: quoted one.
_KEY = re.compile(r"""(?P<key>"[^"]*"|'[^']*'|[^\s#'"{\[][^#]*?)\s*:(?:\s|$)""")


@dataclass(frozen=True, slots=True)
class Cursor:
    """What the cursor is in.

    ``path`` leads to the mapping or list the cursor's text belongs to; ``role`` says whether
    a key of that mapping is being written (``key``) or a value or list entry (``value``).
    ``text`` is the scalar written so far up to the cursor (unquoted), ``start`` the column
    where it begins on the cursor's line.
    """

    path: tuple[str, ...]
    role: Literal["key", "value"]
    text: str
    start: int


@dataclass(frozen=True, slots=True)
class _Line:
    """One line's block structure: indentation, list dashes and a key at its content."""

    indent: int
    dashes: tuple[int, ...]  # columns of `- ` list markers before the content
    content: int  # column where the content after the dashes starts
    key: str | None
    after_key: int  # column just after `key:` (when there is a key)


def _strip_quotes(key: str) -> str:
    if len(key) >= 2 and key[0] == key[-1] and key[0] in "'\"":
        return key[1:-1]
    return key.strip()


def _structure(line: str) -> _Line:
    indent = len(line) - len(line.lstrip(" "))
    column = indent
    dashes: list[int] = []
    while line.startswith("- ", column) or line[column:] == "-":
        dashes.append(column)
        column += 1
        while column < len(line) and line[column] == " ":
            column += 1
    match = _KEY.match(line, column)
    if match is None:
        return _Line(indent, tuple(dashes), column, None, column)
    return _Line(indent, tuple(dashes), column, _strip_quotes(match["key"]), match.end())


def _blank(line: str) -> bool:
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def _parents(lines: list[str], row: int, limit: int) -> list[str]:
    """Keys and list entries enclosing column ``limit`` of line ``row``, outermost first."""
    path: list[str] = []
    for above in range(row - 1, -1, -1):
        if limit <= 0:
            break
        text = lines[above]
        if _blank(text) or text.lstrip().startswith(("---", "...")):
            continue
        shape = _structure(text)
        if shape.key is not None and shape.content < limit:
            path.append(shape.key)
            limit = shape.content
        for dash in reversed(shape.dashes):
            if dash < limit:
                path.append(ITEM)
                limit = dash
        if shape.key is None and not shape.dashes and shape.indent < limit:
            limit = shape.indent  # a continuation line of a scalar: no structure of its own
    return list(reversed(path))


def _flow(text: str) -> tuple[list[str], Literal["key", "value"], int] | None:
    """The flow collections open at the end of ``text`` (a value written after ``key:``).

    Returns the path inside them, the role of what is written last and the offset where it
    starts; None when ``text`` opens no collection (a plain or quoted scalar).
    """
    stack: list[tuple[str, str | None]] = []  # ("map", current key) or ("seq", None)
    start = 0
    role: Literal["key", "value"] = "value"
    index = 0
    quote: str | None = None
    while index < len(text):
        char = text[index]
        if quote is not None:
            if char == quote:
                quote = None
        elif char in "'\"" and text[start:index].strip() == "":
            quote = char
        elif char == "{":
            stack.append(("map", None))
            start, role = index + 1, "key"
        elif char == "[":
            stack.append(("seq", None))
            start, role = index + 1, "value"
        elif char in "}]":
            if stack:
                stack.pop()
            start = index + 1
        elif char == ",":
            if stack and stack[-1][0] == "map":
                stack[-1] = ("map", None)
                role = "key"
            start = index + 1
        elif char == ":" and (index + 1 == len(text) or text[index + 1] in " \t"):
            if stack and stack[-1][0] == "map":
                stack[-1] = ("map", _strip_quotes(text[start:index]))
                role = "value"
            start = index + 1
        index += 1
    if not stack:
        return None
    path: list[str] = []
    for kind, key in stack[:-1]:
        if kind == "seq":
            path.append(ITEM)
        elif key is not None:
            path.append(key)
    kind, key = stack[-1]
    if kind == "seq":
        path.append(ITEM)
        role = "value"
    elif key is not None and role == "value":
        path.append(key)
    while start < len(text) and text[start] == " ":
        start += 1
    return path, role, start


def cursor_at(text: str, line: int, column: int) -> Cursor:
    """The cursor's context at 0-based ``line`` and ``column`` (characters) of ``text``."""
    lines = text.split("\n")
    if line >= len(lines):
        return Cursor((), "key", "", 0)
    current = lines[line].rstrip("\r")[:column]
    shape = _structure(current)
    if current.strip() == "":
        return Cursor(tuple(_parents(lines, line, column)), "key", "", column)
    path: list[str]
    if shape.dashes:
        path = [*_parents(lines, line, shape.dashes[0]), *([ITEM] * len(shape.dashes))]
    else:
        path = _parents(lines, line, shape.content)
    if shape.key is None:
        after = shape.content
        role: Literal["key", "value"] = "value" if shape.dashes else "key"
    else:
        path.append(shape.key)
        after, role = shape.after_key, "value"
    inside = _flow(current[after:])
    if inside is None:
        return _scalar(path, current, after, role)
    deeper, role, start = inside
    begin = after + start
    return Cursor((*path, *deeper), role, _unquoted(current[begin:]), begin)


def _scalar(path: list[str], current: str, begin: int, role: Literal["key", "value"]) -> Cursor:
    while begin < len(current) and current[begin] == " ":
        begin += 1
    return Cursor(tuple(path), role, _unquoted(current[begin:]), begin)


def _unquoted(text: str) -> str:
    return text[1:] if text[:1] in ("'", '"') else text


#: A dotted word: parts starting with a letter, ``_`` or ``$`` (a component, a plain port).
_DOTTED = r"[A-Za-z_$][\w$:-]*(?:\.[A-Za-z_$][\w$:-]*)*"
#: A port name between double quotes after the component (``p."input.1"``): the quotes hold
#: the whole name, which holds no ``"`` (:data:`fmionnx.spec.runspec.ENDPOINT_RE`).
_QUOTED_PORT = r'\."[^"\n]+"'

#: A name as the checks language and endpoints write it, up to the cursor: a dotted name, or
#: one whose quoted port is being written (``p."inp``, its closing quote not yet typed).
_NAME_TAIL = re.compile(_DOTTED + r'(?:\.(?:"[^"\n]*"?)?)?$')


def name_before(text: str) -> str:
    """The dotted name that ends ``text`` (``final(odometry.po`` -> ``odometry.po``,
    ``record: [p."inp`` -> ``p."inp``)."""
    match = _NAME_TAIL.search(text)
    return match.group(0) if match else ""


def split_typed_port(typed: str) -> tuple[str, str]:
    """A name being typed as (what comes before its last part, that part): the part is
    everything from an opening quote (``p."input.1`` -> ``p``, ``"input.1``), which may hold
    dots, else what follows the last dot (``sub.gain.y`` -> ``sub.gain``, ``y``)."""
    head, quote, port = typed.partition('."')
    if quote:
        return head, '"' + port
    head, _, partial = typed.rpartition(".")
    return head, partial


#: A dotted name, its port quoted or not, with an optional element index, as hover,
#: definition and rename look it up (``world.base_quat[0]``, ``p."12"[1]``).
NAME = re.compile(_DOTTED + f"(?:{_QUOTED_PORT})?" + r"(?:\[[\d,\s]*\])?")
#: A name whose port is quoted: the owner and the port name (no index).
_QUOTED_NAME = re.compile(r"(?P<owner>" + _DOTTED + r')\."(?P<port>[^"\n]+)"')


def quoted_port(name: str) -> tuple[str, str] | None:
    """(component, port) of a name with a quoted port (``p."12"``); None for any other."""
    match = _QUOTED_NAME.fullmatch(name)
    return (match["owner"], match["port"]) if match else None


def name_at(line_text: str, column: int) -> tuple[str, int] | None:
    """The dotted name under ``column`` of a line and the column it starts at, or None.

    A quoted port is part of the name (``p."input.1"``): the words inside the quotes are the
    port's, never names of their own (a component ``input`` is not named by it).
    """
    for match in NAME.finditer(line_text):
        name = match.group(0).rstrip(":")  # `key:` ends a key, it is no part of the name
        if match.start() <= column <= match.start() + len(name) and name:
            return name, match.start()
    return None
