"""The editor set-ups: the VS Code extension's manifest and entry start `fmionnx lsp` for
fmionnx's files, its packaging leaves nothing in the tree, and the Helix configuration in
docs/editors.md is valid TOML naming the server (nothing here needs the network)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tomllib

import pytest

from tests.conftest import REPO

VSCODE = REPO / "editors" / "vscode"


def test_the_manifest_is_valid_json_starting_the_server_for_fmionnx_files() -> None:
    manifest = json.loads((VSCODE / "package.json").read_text(encoding="utf-8"))
    assert manifest["name"] == "fmionnx"
    assert (VSCODE / manifest["main"]).is_file()
    assert "onLanguage:yaml" in manifest["activationEvents"]
    assert manifest["contributes"]["languages"] == [{"id": "xml", "extensions": [".ssd"]}]
    setting = manifest["contributes"]["configuration"]["properties"]["fmionnx.command"]
    assert setting["default"] == "fmionnx"
    assert set(manifest["dependencies"]) == {"vscode-languageclient"}
    entry = (VSCODE / manifest["main"]).read_text(encoding="utf-8")
    assert 'args: ["lsp"]' in entry
    assert '{ scheme: "file", language: "yaml" }' in entry
    assert '{ scheme: "file", pattern: "**/*.ssd" }' in entry


def test_the_entry_is_valid_javascript() -> None:
    node = shutil.which("node")
    if node is None:
        pytest.skip("Node.js is not installed here")
    subprocess.run([node, "--check", str(VSCODE / "extension.js")], check=True)


def test_packaging_builds_in_a_scratch_folder_into_build() -> None:
    script = (VSCODE / "package.sh").read_text(encoding="utf-8")
    assert (VSCODE / "package.sh").stat().st_mode & 0o111
    assert "mktemp -d" in script
    assert "@vscode/vsce" in script
    assert "build/vscode" in script
    ignored = (REPO / ".gitignore").read_text(encoding="utf-8").split()
    assert "build/" in ignored
    assert "node_modules/" in ignored
    assert "*.vsix" in ignored
    tracked = subprocess.run(
        ["git", "ls-files", "editors"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.split()
    assert not [f for f in tracked if "node_modules" in f or f.endswith(".vsix")]


def test_the_helix_configuration_in_the_docs_is_valid_toml() -> None:
    text = (REPO / "docs" / "editors.md").read_text(encoding="utf-8")
    [block] = re.findall(r"```toml\n(.*?)```", text, flags=re.DOTALL)
    config = tomllib.loads(block)
    assert config["language-server"]["fmionnx"] == {"command": "fmionnx", "args": ["lsp"]}
    by_name = {language["name"]: language for language in config["language"]}
    assert "fmionnx" in by_name["yaml"]["language-servers"]
    assert by_name["ssd"]["file-types"] == ["ssd"]
    assert by_name["ssd"]["language-servers"] == ["fmionnx"]
