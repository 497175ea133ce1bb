"""A component kind is one module (or package) plus its line in the kind table.

No module outside a kind's own names it: no string constant equal to a kind's name appears
anywhere else in the package, so adding a kind cannot need edits elsewhere.
"""

from __future__ import annotations

import ast
from pathlib import Path

from fmionnx.kinds.registry import COMPONENT_KINDS

PACKAGE = Path(__file__).resolve().parents[2] / "fmionnx"
#: The table that registers the kinds (imports them by module, names none as a string).
REGISTRY = PACKAGE / "kinds" / "registry.py"


def _own_files(kind: str) -> set[Path]:
    folder = PACKAGE / "kinds" / kind
    if folder.is_dir():
        return set(folder.rglob("*.py"))
    return {PACKAGE / "kinds" / f"{kind}.py"}


def _constants(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    return {
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and id(node) not in docstrings
    }


def test_every_kind_lives_in_its_own_module() -> None:
    for name in COMPONENT_KINDS:
        assert _own_files(name), f"kind `{name}` has no module fmionnx/kinds/{name}[.py]"


def test_no_module_outside_a_kind_names_it() -> None:
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        constants = _constants(path)
        for name in COMPONENT_KINDS:
            if path in _own_files(name) or path == REGISTRY:
                continue
            if name in constants:
                offenders.append(f"{path.relative_to(PACKAGE.parent)} names `{name}`")
    assert offenders == []


def test_the_check_sees_a_kind_name(tmp_path: Path) -> None:
    """The check itself: a literal kind name in code is found, a docstring mention is not."""
    sample = tmp_path / "sample.py"
    sample.write_text('"""Runs an fmu."""\n\nKIND = "fmu"\n', encoding="utf-8")
    assert _constants(sample) == {"fmu"}
