"""``fmionnx lsp`` as a command: registered like the others, free for the others' start-up,
and a clear install hint (exit 1) where the ``lsp`` extra is missing."""

from __future__ import annotations

import subprocess
import sys

from tests.cli.test_help_texts import help_text


def test_lsp_help_says_what_the_server_does() -> None:
    text = help_text("lsp")
    assert "Run the language server for system, study and SSD files over stdin/stdout" in text
    assert "see docs/editors.md for VS Code, Neovim and Helix" in text


def test_the_cli_imports_no_language_server_library() -> None:
    code = (
        "import sys, fmionnx.cli\n"
        "print(','.join(m for m in ('pygls', 'lsprotocol', 'fmionnx.lsp') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == ""


def test_without_the_extra_the_command_says_how_to_install_it() -> None:
    code = (
        "import sys\n"
        "sys.modules['pygls'] = None  # as if the `lsp` extra were not installed\n"
        "sys.argv = ['fmionnx', 'lsp']\n"
        "from fmionnx.cli import main\n"
        "main()\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=False,
        env={"COLUMNS": "200", "PATH": "/usr/bin:/bin"},
    )
    assert done.returncode == 1
    assert done.stdout == ""
    message = " ".join(done.stderr.split())
    assert "error: `fmionnx lsp` needs the language-server extra (pygls)" in message
    assert "pip install -e '.[lsp]'" in message
    assert "Traceback" not in done.stderr
