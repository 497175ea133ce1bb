"""A lock file is read within the same YAML limits as a system file (E082 at the position).

The fast path (libyaml's safe loader, then validation) used to run before any check, so an
alias bomb in a lock file grew without bound and a 5000-digit integer ended in a ValueError.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.lock.read import read_lock
from fmionnx.spec.limits import MAX_DEPTH
from tests.lock.conftest import GAIN, write_and_read


def _read(tmp_path: Path, text: str) -> DiagnosticBag:
    path = tmp_path / "system.fmionnx.lock"
    path.write_text(text, encoding="utf-8")
    bag = DiagnosticBag()
    assert read_lock(path, tmp_path / "system.yaml", bag) is None
    return bag


def where(diagnostic: Diagnostic) -> tuple[int, int]:
    assert diagnostic.span is not None
    return diagnostic.span.line, diagnostic.span.col


def bomb(levels: int) -> str:
    """``10**levels`` strings once the aliases of the document expand."""
    lines = ["a0: &a0 [" + ", ".join(["lol"] * 10) + "]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


def test_alias_bomb_in_a_lock_is_e082_at_the_alias(tmp_path: Path) -> None:
    text = "fmionnx-lock: 1\nsystem: system.yaml\ncomponents: {}\n" + bomb(12)
    (diagnostic,) = list(_read(tmp_path, text))
    assert diagnostic.code == "E082"
    assert "aliases expand to more than" in diagnostic.message
    assert where(diagnostic) == (7, 45)
    assert "regenerate it" in (diagnostic.hint or "")


def test_deep_nesting_in_a_lock_is_e082(tmp_path: Path) -> None:
    text = "fmionnx-lock: 1\nsystem: system.yaml\ncomponents: " + "[" * 50_000 + "\n"
    (diagnostic,) = list(_read(tmp_path, text))
    assert diagnostic.code == "E082"
    assert f"more than {MAX_DEPTH} levels deep" in diagnostic.message
    assert where(diagnostic)[0] == 3


def test_huge_integer_in_a_lock_is_e082(tmp_path: Path) -> None:
    text = "fmionnx-lock: " + "1" * 5000 + "\nsystem: system.yaml\ncomponents: {}\n"
    (diagnostic,) = list(_read(tmp_path, text))
    assert diagnostic.code == "E082"
    assert "beyond the range of a 64-bit float" in diagnostic.message
    assert where(diagnostic) == (1, 15)


def test_an_ordinary_lock_still_reads(tmp_path: Path) -> None:
    assert write_and_read(tmp_path, GAIN).lock.components
