"""Diagnostic codes are symbols (``codes.UNKNOWN_PORT``), defined once in ``core/codes.py``.

A misspelt symbol fails at import; a bare code string (``"E021"``) anywhere else in the
package would fail only when the diagnostic is made, so none is allowed (docstrings aside).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.codes import CODES, ErrorCode

PACKAGE = Path(__file__).resolve().parents[2] / "fmionnx"
TABLE = PACKAGE / "core" / "codes.py"
CODE = re.compile(r"^[EWI]\d{3}$")


def _docstrings(tree: ast.AST) -> set[int]:
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                found.add(id(body[0].value))
    return found


def bare_codes(source: str) -> list[tuple[int, str]]:
    """``(line, code)`` for every code string in ``source`` outside its docstrings."""
    tree = ast.parse(source)
    skip = _docstrings(tree)
    return sorted(
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and CODE.match(node.value)
        and id(node) not in skip
    )


def test_no_bare_code_string_outside_the_table() -> None:
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{line}: {code!r}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != TABLE
        for line, code in bare_codes(path.read_text(encoding="utf-8"))
    ]
    assert found == [], "name the code by its symbol in fmionnx.core.codes"


def test_the_check_sees_a_bare_code_and_not_a_docstring() -> None:
    source = '"""About E021."""\n\ndef f():\n    """E022 too."""\n    bag.emit("E021", "x")\n'
    assert bare_codes(source) == [(5, "E021")]


def test_every_symbol_is_in_the_table_under_its_name() -> None:
    symbols = {name: value for name, value in vars(codes).items() if isinstance(value, ErrorCode)}
    assert sorted(entry.code for entry in symbols.values()) == sorted(CODES)
    for name, entry in symbols.items():
        assert name == entry.name.upper().replace("-", "_")
        assert CODES[entry.code] is entry
