"""Helpers shared by the machine-readable reporters (json, github, sarif, junit).

CI systems resolve report paths against the repository checkout, which is almost always the
working directory of the ``fmionnx validate`` call; so every path inside the working directory
is written relative to it (POSIX separators), and only paths outside it stay absolute.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path

from fmionnx.core.diagnostics import Diagnostic, Span
from fmionnx.core.pathnames import archive_member


def display_path(path: Path, cwd: Path | None = None) -> str:
    """``path`` relative to ``cwd`` (default: the working directory) when inside it.

    Symbolic links are not resolved: a system file reached through a link is reported under
    the name the user gave, which is the name the CI checkout has. A file inside an unpacked
    archive is named ``archive!/member`` (:mod:`fmionnx.core.pathnames`).
    """
    member = archive_member(path)
    if member is not None:
        return f"{display_path(member[0], cwd)}!/{member[1]}"
    base = Path(os.path.normpath((cwd or Path.cwd()).absolute()))
    absolute = Path(os.path.normpath(path.absolute()))
    try:
        return absolute.relative_to(base).as_posix()
    except ValueError:
        return absolute.as_posix()


def located(diagnostic: Diagnostic, system: Path) -> Span:
    """The diagnostic's span, or the whole system file when it has none.

    Annotation consumers (GitHub, SARIF viewers) drop findings without a location, and a
    finding about a system file belongs to that file.
    """
    return diagnostic.span if diagnostic.span is not None else Span(system)


def detail_lines(diagnostic: Diagnostic) -> list[str]:
    """Notes and hint as plain lines, for formats that have one free-text field."""
    lines = []
    for note in diagnostic.notes:
        where = ""
        if note.span is not None:
            where = display_path(note.span.file)
            if note.span.line > 0:
                where += f":{note.span.line}"
                if note.span.col > 0:
                    where += f":{note.span.col}"
            where += ": "
        lines.append(f"note: {where}{note.message}")
    if diagnostic.hint:
        lines.append(f"hint: {diagnostic.hint}")
    return lines


def full_text(diagnostic: Diagnostic) -> str:
    """Message, then notes and hint on their own lines."""
    return "\n".join([diagnostic.message, *detail_lines(diagnostic)])


#: Diagnostics of one code shown per file by the reports people read (text, GitHub
#: annotations); the rest are counted in one line. A generated or hostile file can hold
#: hundreds of thousands of the same mistake: the first ones say what is wrong.
SHOWN_PER_CODE = 20


def capped(diagnostics: Iterable[Diagnostic]) -> Iterator[Diagnostic | tuple[str, int]]:
    """``diagnostics`` in order, at most :data:`SHOWN_PER_CODE` of each code; then, for each
    code with more, ``(code, how many were left out)``."""
    seen: dict[str, int] = {}
    for diagnostic in diagnostics:
        count = seen.get(diagnostic.code, 0) + 1
        seen[diagnostic.code] = count
        if count <= SHOWN_PER_CODE:
            yield diagnostic
    for code, count in seen.items():
        if count > SHOWN_PER_CODE:
            yield code, count - SHOWN_PER_CODE


def left_out(code: str, count: int) -> str:
    """The line that stands for ``count`` diagnostics of ``code`` not shown."""
    from fmionnx.core.diagnostics import CODES

    entry = CODES.get(code)
    name = f" {entry.name}" if entry is not None else ""
    what = "diagnostic" if count == 1 else "diagnostics"
    return (
        f"... and {count} more {what} [{code}{name}] in this file, not shown (the first "
        f"{SHOWN_PER_CODE} are; `--format json` lists every one)"
    )
