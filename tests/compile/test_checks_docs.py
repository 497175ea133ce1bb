"""The statements docs/checks.md offers compile against the reference scenario as written."""

from __future__ import annotations

import re
from pathlib import Path

from fmionnx import api
from tests.conftest import REPO

DOC = REPO / "docs" / "checks.md"
REFERENCE = REPO / "systems" / "sign_follower.yaml"


def _documented_statements() -> list[str]:
    text = DOC.read_text(encoding="utf-8")
    table = text.split("### Common statements", 1)[1].split("\n## ", 1)[0]
    found = re.findall(r"^\| [^|]+ \| `([^`]+)` \|$", table, flags=re.MULTILINE)
    return [f for f in found if "plant." not in f]  # the rest name a model of no system here


def test_every_common_statement_of_the_docs_compiles_on_the_reference(tmp_path: Path) -> None:
    statements = _documented_statements()
    assert len(statements) >= 6
    text = REFERENCE.read_text(encoding="utf-8").replace("path: ../", f"path: {REPO.as_posix()}/")
    text = text.split("\nchecks:", 1)[0] + "\nchecks:\n"
    text += "".join(f"  - name: s{i}\n    expect: {s}\n" for i, s in enumerate(statements))
    system = tmp_path / "documented.yaml"
    system.write_text(text, encoding="utf-8")
    result = api.compile_system(system)
    errors = [str(d) for d in result.diagnostics if d.severity.label == "error"]
    assert errors == []
    assert result.system is not None
    assert [c.expression for c in result.system.checks] == statements
