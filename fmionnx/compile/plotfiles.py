"""The file name of each plot: chosen at compile time, plain, unique, inside ``--out``.

A plot with a ``file`` keeps it (``.png`` added when it names no image format). Any other plot
is named after its title, the way a person would name the file: ``Trajectory A -> B`` becomes
``trajectory-a-b.png`` (lower case, every run of other characters one ``-``, at most
:data:`STEM_LENGTH` characters). Without a title the name comes from what it draws:
``trajectory`` for an xy plot over a reference, ``<y> vs <x>`` for another xy plot, the
signals' names for a time plot. A name already taken gets ``-2``, ``-3``, ...; the names other
results use (:data:`RESERVED`) are never given to a derived name.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

#: Image formats matplotlib writes that a plot's ``file`` may end in.
IMAGE_SUFFIXES = (".png", ".svg", ".pdf")
#: Longest derived stem: long titles make unwieldy file names.
STEM_LENGTH = 60
#: ``run --plot`` writes the recorded signals here; a derived plot name never takes it.
SIGNALS_FILE = "signals.png"
#: Names a derived plot name never takes.
RESERVED = frozenset({SIGNALS_FILE})


def slug(text: str) -> str:
    """``Trajectory A -> B`` -> ``trajectory-a-b``: lower-case ASCII letters, digits and ``-``."""
    stem = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")
    return stem[:STEM_LENGTH].rstrip("-") or "plot"


def with_suffix(name: str) -> str:
    """A given file name, with ``.png`` when it names no image format."""
    return name if name.endswith(IMAGE_SUFFIXES) else name + ".png"


def derived_stem(
    title: str | None, xy: tuple[str, str] | None, y: Iterable[str], over: bool
) -> str:
    """The stem a plot without ``file`` is named by (not yet unique)."""
    if title and title.strip():
        return slug(title)
    if xy is not None:
        return "trajectory" if over else slug(f"{xy[1]} vs {xy[0]}")
    return slug(" ".join(y))


def unique_name(stem: str, taken: set[str], suffix: str = ".png") -> str:
    """``stem + suffix``, or ``stem-2 + suffix``, ... : the first not in ``taken`` (added)."""
    name, number = stem + suffix, 1
    while name in taken or name in RESERVED:
        number += 1
        name = f"{stem}-{number}{suffix}"
    taken.add(name)
    return name
