"""The rich consoles commands print through: tables are never cut where no terminal is.

rich lays out for a terminal of ``COLUMNS`` columns, and without a terminal (output piped,
redirected to a file, a CI log) and without ``COLUMNS`` it assumes 80: a table wider than that
is squeezed, its cells wrapped or cut with ``…`` — the very file names a user needs (``wrote
… heatmap-distance…``), headers such as ``tracker.cr…``. A file or a pipe has no width, so
there the consoles here lay out as wide as the content (up to :data:`UNBOUNDED` columns). On a
terminal rich takes the terminal's width; an explicit ``COLUMNS`` always wins (the docs tests
and golden outputs fix it at 80). Recorded in docs/decisions.md.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console

#: Columns a console without a terminal lays out in: wider than any row fmionnx prints, so
#: a table is as wide as its content (rich pads nothing to the width of a console).
UNBOUNDED = 10_000


def width_for(console: Console) -> int | None:
    """The width to give ``console``: None (keep rich's) on a terminal or with ``COLUMNS``."""
    if console.is_terminal or os.environ.get("COLUMNS", "").strip():
        return None
    return UNBOUNDED


def make_console(*, stderr: bool = False, soft_wrap: bool = False) -> Console:
    """A console on stdout (or stderr) for tables and messages, see the module's docstring.

    ``soft_wrap``: long lines are left to the terminal instead of being broken by rich, so a
    message copied from the terminal (a command in it, a path) comes out whole.
    """
    from rich.console import Console

    console = Console(stderr=stderr, highlight=False, soft_wrap=soft_wrap)
    width = width_for(console)
    if width is not None:
        console.width = width
    return console
