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


def test_the_readme_undoes_the_mistake_it_makes() -> None:
    """The tour breaks `systems/sign_follower.yaml` on purpose (issue #34: it never said how to
    undo it). The same transcript undoes it, and the docs test runs it: the file validates."""
    from tests.test_docs_examples import parse_blocks

    breaking = "sed -i 's/odometry.theta ->/odometry.thta ->/' systems/sign_follower.yaml"
    undoing = "sed -i 's/odometry.thta ->/odometry.theta ->/' systems/sign_follower.yaml"
    (block,) = [b for b in parse_blocks(REPO / "README.md") if f"$ {breaking}" in b.body]
    assert "not-run" not in block.markers
    commands = [c.text.split("  #")[0].strip() for c in block.commands()]
    assert commands.index(undoing) > commands.index(breaking)
    last = block.commands()[-1]
    assert last.text == "fmionnx validate systems/sign_follower.yaml"
    assert last.expected == ["no problems in 1 file"]


def test_the_readme_says_what_the_detector_is() -> None:
    """Not "a CNN": a convolutional network with hand-set weights (issue #34)."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert "CNN" not in text
    assert "weights are set by hand" in text
    assert "docs/models/sign_detector.md" in text


def test_examples_need_only_the_demo_set_up() -> None:
    """`make setup` installs the test extras (minutes more); the examples need the package."""
    for readme in sorted((REPO / "examples").glob("**/README.md")):
        text = readme.read_text(encoding="utf-8")
        assert not re.search(r"`make setup( models)?`", text), readme
        if readme.parent.name != "examples":  # an example, not the index
            assert "`make setup-demo models`" in text, readme
