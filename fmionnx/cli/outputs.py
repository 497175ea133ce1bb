"""Output paths given on the command line, checked before any work starts (exit 2 with the
option's name; the rules are :mod:`fmionnx.pipeline.outputs`')."""

from __future__ import annotations

from pathlib import Path

from fmionnx.cli.app import refused
from fmionnx.pipeline import outputs


def check_output_file(path: Path, option: str) -> Path:
    """``path`` can be written as a file (its folder is created); else exit 2."""
    with refused():
        return outputs.check_output_file(path, option)


def check_output_folder(path: Path, option: str) -> Path:
    """``path`` is (or can be created as) a writable folder; else exit 2."""
    with refused():
        return outputs.check_output_folder(path, option)
