"""``validate``'s diagnostics as LSP diagnostics, per file they point into.

Each keeps its code (``E021``), severity, message and hint (``hint:`` on its own line, as the
text report prints it). A note with a place becomes related information at that place; so
does a note that names where a port is declared in an FMU's ``modelDescription.xml`` (``theta``
is declared at ``ReadOdometry.fmu/modelDescription.xml:57``) or the model the ports are read
from: the location is the model description an editor can open
(:mod:`fmionnx.lsp.declarations`). Other notes stay text in the message.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from lsprotocol import types

from fmionnx.core.diagnostics import Diagnostic, Note, Severity
from fmionnx.core.types import ComponentInterface
from fmionnx.lsp.analysis import Analysis
from fmionnx.lsp.declarations import Place, model_place, port_place
from fmionnx.lsp.outline import Outline
from fmionnx.lsp.positions import line_range, span_range

#: Where the diagnostics come from, as editors show it.
SOURCE = "fmionnx"

_SEVERITY = {
    Severity.ERROR: types.DiagnosticSeverity.Error,
    Severity.WARNING: types.DiagnosticSeverity.Warning,
    Severity.INFO: types.DiagnosticSeverity.Information,
}

#: `x` is declared at Model.fmu/modelDescription.xml:57 (:func:`fmionnx.compile.typecheck.declared_note`)
_DECLARED_AT = re.compile(
    r"`(?P<port>[^`]+)` is declared at (?P<model>[^/`]+)/[^:`]+:(?P<line>\d+)"
)
#: ports are read from `Model.fmu` (:func:`fmionnx.compile.endpoints.resolve_endpoint`)
_READ_FROM = re.compile(r"read from `(?P<model>[^`]+)`")

Lines = Callable[[Path], Sequence[str]]


@dataclass(frozen=True, slots=True)
class Published:
    """One LSP diagnostic and the fmionnx diagnostic it shows (for code actions and hover)."""

    lsp: types.Diagnostic
    source: Diagnostic | None


def uri_of(path: Path) -> str:
    """The ``file:`` URI of a path (absolute and normalised, as editors name files)."""
    return Path(os.path.normpath(path.absolute())).as_uri()


def convert(analysis: Analysis, lines_of: Lines) -> dict[Path, list[Published]]:
    """Every diagnostic of ``analysis``, by the file it is in (the analysed file for one
    without a place); the analysed file is always a key, so its old diagnostics are cleared."""
    by_file: dict[Path, list[Published]] = {analysis.path: []}
    if analysis.failure is not None:
        lsp = types.Diagnostic(
            range=line_range(lines_of(analysis.path), 0),
            message=analysis.failure,
            severity=types.DiagnosticSeverity.Error,
            source=SOURCE,
        )
        by_file[analysis.path].append(Published(lsp, None))
    outlines = _outlines(analysis.outline)
    for diagnostic in analysis.diagnostics:
        file = analysis.path if diagnostic.span is None else _absolute(diagnostic.span.file)
        lsp = to_lsp(diagnostic, lines_of(file), outlines, lines_of)
        by_file.setdefault(file, []).append(Published(lsp, diagnostic))
    return by_file


def to_lsp(
    diagnostic: Diagnostic,
    lines: Sequence[str],
    outlines: Sequence[Outline],
    lines_of: Lines,
) -> types.Diagnostic:
    """One diagnostic; ``lines`` are its file's."""
    related: list[types.DiagnosticRelatedInformation] = []
    text_notes: list[str] = []
    for note in diagnostic.notes:
        location = _note_location(note, outlines, lines_of)
        if location is None:
            text_notes.append(f"note: {note.message}")
        else:
            related.append(types.DiagnosticRelatedInformation(location, note.message))
    hint = [f"hint: {diagnostic.hint}"] if diagnostic.hint else []
    return types.Diagnostic(
        range=span_range(diagnostic.span, lines, code=diagnostic.code),
        message="\n".join([diagnostic.message, *text_notes, *hint]),
        severity=_SEVERITY[diagnostic.severity],
        code=diagnostic.code,
        source=SOURCE,
        related_information=related or None,
    )


def _absolute(path: Path) -> Path:
    return path if path.is_absolute() else Path.cwd() / path


def _outlines(outline: Outline | None) -> list[Outline]:
    found: list[Outline] = []
    while outline is not None:
        found.append(outline)
        outline = outline.system
    return found


def _note_location(
    note: Note, outlines: Sequence[Outline], lines_of: Lines
) -> types.Location | None:
    if note.span is not None:
        file = _absolute(note.span.file)
        if not file.is_file():
            return None
        lines = lines_of(file)
        return types.Location(uri_of(file), span_range(note.span, lines))
    place = _model_note_place(note.message, outlines)
    if place is None:
        return None
    row = max(place.line - 1, 0)
    return types.Location(uri_of(place.file), line_range(lines_of(place.file), row))


def _model_note_place(message: str, outlines: Sequence[Outline]) -> Place | None:
    """The model file place a note names: a port's declaration, or the model itself."""
    declared = _DECLARED_AT.search(message)
    if declared is not None:
        interface = _interface_of(declared["model"], outlines)
        if interface is None:
            return None
        port = interface.port(declared["port"])
        if port is not None:
            return port_place(interface, port)
        return None
    read_from = _READ_FROM.search(message)
    if read_from is not None:
        interface = _interface_of(read_from["model"], outlines)
        return model_place(interface) if interface is not None else None
    return None


def _interface_of(model_name: str, outlines: Sequence[Outline]) -> ComponentInterface | None:
    for outline in outlines:
        for component in outline.components.values():
            if component.interface is not None and component.interface.path.name == model_name:
                return component.interface
    return None
