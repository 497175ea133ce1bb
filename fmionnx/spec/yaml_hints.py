"""Hints for YAML syntax errors whose cause is a system-file habit, not YAML itself.

An endpoint with an element index written inside a flow collection, ``{from: a.y, to:
g.v[0]}`` or ``[a.w[0] -> g.u]``, is not valid YAML: inside ``{...}`` and ``[...]`` a plain
scalar ends at ``[``, which opens a list. The parser then says "expected ',' or '}', but got
'['", which does not tell a user that quoting the endpoint is the fix.
"""

from __future__ import annotations

#: Characters that end a plain scalar inside a flow collection (YAML 1.2, flow indicators).
_FLOW_INDICATORS = ",[]{}"


def flow_index_hint(text: str, line: int, column: int, problem: str) -> str | None:
    """A "quote the endpoint" hint when the error at ``line``/``column`` (0-based) is a ``[``
    glued to a plain scalar inside a flow collection; None for any other error.
    """
    if not (problem.startswith("expected ',' or ") and problem.endswith("but got '['")):
        return None
    lines = text.splitlines()
    if not 0 <= line < len(lines):
        return None
    row = lines[line]
    if not 0 < column < len(row) or row[column] != "[":
        return None
    if row[column - 1].isspace() or row[column - 1] in _FLOW_INDICATORS + ":":
        return None  # `[` after a space or an indicator really is a list: another mistake
    token = _start(row, column) + _rest(row, column)
    if not token:
        return None
    return (
        f"quote the endpoint: '{token}' (inside `{{...}}` and `[...]` YAML reads `[` as the "
        "start of a list)"
    )


def _start(row: str, column: int) -> str:
    """The plain scalar before the ``[``: back to a space after ``:``, or an indicator."""
    begin = column
    while begin > 0 and row[begin - 1] not in _FLOW_INDICATORS:
        if row[begin - 1] == " " and begin >= 2 and row[begin - 2] == ":":
            break
        begin -= 1
    return row[begin:column].strip()


def _rest(row: str, column: int) -> str:
    """From the ``[`` to the end of the flow item: a ``,``, ``}`` or ``]`` outside brackets."""
    depth = 0
    end = column
    while end < len(row):
        char = row[end]
        if char == "[":
            depth += 1
        elif char == "]":
            if depth == 0:
                break
            depth -= 1
        elif depth == 0 and (char in ",}" or (char == "#" and row[end - 1].isspace())):
            break  # the item ends, or a comment starts
        end += 1
    return row[column:end].rstrip()
