"""The pre-commit manifest is valid for pre-commit itself and names real commands."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from pre_commit.clientlib import load_manifest
from typer.testing import CliRunner

from fmionnx.cli.app import app

REPO = Path(__file__).resolve().parents[2]
HOOKS = {hook["id"]: hook for hook in load_manifest(str(REPO / ".pre-commit-hooks.yaml"))}


def test_manifest_offers_the_validate_hooks() -> None:
    assert set(HOOKS) == {"fmionnx-validate", "fmionnx-validate-locked"}


@pytest.mark.parametrize("hook", sorted(HOOKS))
def test_hook_entry_is_a_working_fmionnx_command(hook: str) -> None:
    program, *args = shlex.split(HOOKS[hook]["entry"])
    assert program == "fmionnx"
    result = CliRunner().invoke(app, [*args, "--help"], catch_exceptions=False)
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(
    ("path", "selected"),
    [
        ("systems/robot.yaml", True),
        ("robots/systems/arm.yml", True),
        ("export/plant.ssp", True),
        (".github/workflows/ci.yml", False),
        ("models/world/scene.xml", False),
        ("mkdocs.yml", False),
    ],
)
def test_validate_hook_selects_system_files_only(path: str, selected: bool) -> None:
    assert bool(re.search(HOOKS["fmionnx-validate"]["files"], path)) is selected


def test_locked_hook_runs_when_a_model_changes() -> None:
    hook = HOOKS["fmionnx-validate-locked"]
    assert hook["pass_filenames"] is False
    for path in ("build/Gain.fmu", "models/detector.onnx", "systems/robot.fmionnx.lock"):
        assert re.search(hook["files"], path), path
