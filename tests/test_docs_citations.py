"""Every test a page of docs/ cites (``tests/x.py::test_name``) exists: the comparison table and
the security table back their claims with tests, and a renamed test must not leave a claim
without one."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.conftest import REPO

CITED = re.compile(r"`(tests/[\w/]+\.py)::(\w+)`")
PAGES = sorted((REPO / "docs").glob("*.md"))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_cited_test_exists(page: Path) -> None:
    for path, name in CITED.findall(page.read_text(encoding="utf-8")):
        source = REPO / path
        assert source.is_file(), f"{page.name} cites {path}, which does not exist"
        text = source.read_text(encoding="utf-8")
        assert re.search(rf"^def {name}\(", text, re.MULTILINE), f"{page.name}: {path}::{name}"


def test_the_comparison_backs_every_fmionnx_claim_with_a_test() -> None:
    text = (REPO / "docs" / "comparison.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    # every table row but the headers (the line above each `|---|` separator)
    headers = {i - 1 for i, line in enumerate(lines) if line.startswith("|---")}
    rows = [
        line
        for i, line in enumerate(lines)
        if line.startswith("| ") and "---" not in line and i not in headers
    ]
    assert rows
    for row in rows:
        assert CITED.search(row), f"a claim without a test: {row[:80]}"
