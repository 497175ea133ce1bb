"""``fmionnx lsp``: the language server for editors (VS Code, Neovim, Helix ...)."""

from __future__ import annotations

from typing import Annotated

import typer

from fmionnx.cli.app import ExitCode, app, fail

#: What to run when the server's library is missing (fmionnx is installed from a clone).
INSTALL_HINT = (
    "`fmionnx lsp` needs the language-server extra (pygls): in your fmionnx clone run "
    "`pip install -e '.[lsp]'` (with the virtual environment fmionnx is installed in)"
)


@app.command(
    epilog="Editors start it themselves; see docs/editors.md for VS Code, Neovim and Helix.\n\n"
    "  fmionnx lsp            # speaks the Language Server Protocol on stdin/stdout",
)
def lsp(
    stdio: Annotated[
        bool,
        typer.Option(
            "--stdio",
            help="Talk over stdin/stdout: the only transport and the default (accepted because "
            "editors pass it).",
        ),
    ] = False,
) -> None:
    """Run the language server for system, study and SSD files over stdin/stdout: the
    diagnostics of `fmionnx validate` as you type, completion and hover from the real model
    interfaces, go to definition, quick fixes and renames.
    """
    del stdio  # stdio is the only transport
    try:
        import pygls  # noqa: F401 - only to know whether the extra is installed
    except ImportError:
        raise fail(INSTALL_HINT, ExitCode.PROBLEMS) from None  # fail escapes the markup
    from fmionnx.lsp.server import serve

    serve()
