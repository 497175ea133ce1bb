"""Where fmionnx keeps what it can make again: one rule for every cache folder.

``$FMIONNX_CACHE/<name>`` when set, else ``$XDG_CACHE_HOME/fmionnx/<name>``, else
``~/.cache/fmionnx/<name>``: unpacked SSPs and the opt-in run-time kernel build live there.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_folder(name: str) -> Path:
    """The cache folder called ``name`` (not created here)."""
    explicit = os.environ.get("FMIONNX_CACHE")
    if explicit:
        return Path(explicit).expanduser() / name
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "fmionnx" / name
