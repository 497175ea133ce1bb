"""Output paths given on the command line, checked before any work starts.

A run that computes for minutes and then cannot write its results is the worst way to learn that
``--out`` names a file or a read-only place; so every command checks its output paths first
(creating missing parent folders, as it would anyway) and exits 2 with the option's name.
"""

from __future__ import annotations

import os
from pathlib import Path

from fmionnx.cli.app import fail


def _make_folder(folder: Path, option: str, what: str) -> None:
    label = f"{option} `{what}`" + ("" if str(folder) == what else f": the folder `{folder}`")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        msg = f"{label} exists and is not a folder"
        raise fail(msg) from None
    except OSError as exc:
        msg = f"{label} cannot be created ({exc.strerror})"
        raise fail(msg) from None
    if not os.access(folder, os.W_OK | os.X_OK):
        msg = f"{label} is not writable"
        raise fail(msg)


def check_output_file(path: Path, option: str) -> Path:
    """``path`` can be written as a file (its folder is created); else exit 2."""
    if path.is_dir():
        msg = f"{option} `{path}` is a folder; expected a file name"
        raise fail(msg)
    if path.exists() and not os.access(path, os.W_OK):
        msg = f"{option} `{path}` exists and is not writable"
        raise fail(msg)
    _make_folder(path.parent, option, str(path))
    return path


def check_output_folder(path: Path, option: str) -> Path:
    """``path`` is (or can be created as) a writable folder; else exit 2."""
    _make_folder(path, option, str(path))
    return path
