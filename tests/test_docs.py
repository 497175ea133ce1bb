"""User docs stay in step with the code: every diagnostic code and CLI command is documented."""

from __future__ import annotations

import re

from fmionnx.cli.app import app
from fmionnx.core.diagnostics import CODES
from tests.conftest import REPO


def test_every_diagnostic_code_has_a_section() -> None:
    text = (REPO / "docs" / "diagnostics.md").read_text(encoding="utf-8")
    sections = set(re.findall(r"^## ([EWI]\d{3})$", text, flags=re.MULTILINE))
    assert sections == set(CODES)


def test_every_cli_command_is_documented() -> None:
    import fmionnx.cli  # noqa: F401 - registers the commands

    text = (REPO / "docs" / "cli.md").read_text(encoding="utf-8")
    names = {c.name or (c.callback.__name__ if c.callback else "") for c in app.registered_commands}
    names |= {g.name or "" for g in app.registered_groups}
    missing = {n for n in names if f"fmionnx {n}" not in text}
    assert not missing, f"document these commands in docs/cli.md: {sorted(missing)}"
