"""Check one open file as ``fmionnx validate`` does, on the editor's text, and outline it.

The diagnostics come from the functions ``validate`` calls (``fmionnx.api.compile_system``
for a system file, YAML or SSD; ``fmionnx.api.check_study`` for a study), run while the open
files' texts stand in for what is on disk (:func:`fmionnx.core.sourcetext.editing`): the same
codes, messages, hints, notes and positions, by construction. Models are read the way
``validate`` reads them, as data (a model description, a protobuf, a scene's XML; an FMU's
shared library is inspected as ELF, never loaded), so a model whose code would crash cannot
take the server down; and each interface is read once per file identity and process (the
compiler's own cache), so a keystroke re-reads no model.

A failure of fmionnx itself while checking (a bug, not a mistake in the file) becomes one
diagnostic at the top of the file saying so, never an exception out of the server.
"""

from __future__ import annotations

import enum
import re
import traceback
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmionnx import api
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.core.sourcetext import editing
from fmionnx.lsp.outline import Outline, outline_loaded, outline_yaml, plain_data
from fmionnx.spec.frontends import load_system
from fmionnx.spec.suffixes import SSP_SUFFIXES
from fmionnx.spec.yaml import is_study_document, read_text

#: Suffixes of YAML files the server checks.
YAML_SUFFIXES = (".yaml", ".yml")


class DocumentKind(enum.Enum):
    """What an open file is, deciding how it is checked."""

    SYSTEM = "system"
    STUDY = "study"
    SSP = "ssp"
    OTHER = "other"


#: The format-version key every system and study file starts with, at the top level.
_FORMAT_KEY = re.compile(r"^fmionnx[ \t]*:", re.MULTILINE)
#: "Not loaded yet" (None is a text that does not load).
_UNREAD: Any = object()


def document_kind(path: Path, text: str, data: Any = _UNREAD) -> DocumentKind:
    """What an open file is (``data``: its text loaded by :func:`plain_data`, when it is).

    A YAML file is fmionnx's when it has the top-level ``fmionnx:`` key that both formats
    require: an editor opens every YAML file of a workspace (CI workflows, compose files),
    and those are not system files with errors. A study names a ``system:`` and no
    ``components:`` (:func:`fmionnx.spec.yaml.is_study_document`, what ``validate`` asks);
    any other such file is checked as a system file, as ``validate`` does.
    """
    suffix = path.suffix.lower()
    if suffix in SSP_SUFFIXES:
        return DocumentKind.SSP
    if suffix in YAML_SUFFIXES and _FORMAT_KEY.search(text):
        loaded = plain_data(path, text) if data is _UNREAD else data
        return DocumentKind.STUDY if is_study_document(loaded) else DocumentKind.SYSTEM
    return DocumentKind.OTHER


@dataclass(frozen=True)
class Analysis:
    """One check of one open file: its text, what it is, ``validate``'s diagnostics (sorted,
    in every file they point into) and its outline (None when the file did not parse)."""

    path: Path
    text: str
    kind: DocumentKind
    diagnostics: tuple[Diagnostic, ...]
    outline: Outline | None
    failure: str | None = None


def analyse(path: Path, texts: Mapping[Path, str]) -> Analysis:
    """Check the open file ``path``; ``texts`` are every open file's text (``path``'s
    included), which stand in for the files on disk."""
    text = texts[path]
    with editing(texts):
        yaml = path.suffix.lower() in YAML_SUFFIXES
        data = plain_data(path, text) if yaml else None
        kind = document_kind(path, text, data)
        failure = None
        try:
            diagnostics = _diagnostics(path, kind)
        except Exception as exc:  # a bug of fmionnx: reported on the file, the server lives
            diagnostics, failure = (), _internal(exc)
        try:
            outline = _outline(path, text, kind, data)
        except Exception:  # the outline only helps completion; its bug must not hide the rest
            outline = None
    return Analysis(path, text, kind, diagnostics, outline, failure)


def _diagnostics(path: Path, kind: DocumentKind) -> tuple[Diagnostic, ...]:
    if kind is DocumentKind.STUDY:
        return api.check_study(path).diagnostics
    if kind in (DocumentKind.SYSTEM, DocumentKind.SSP):
        return api.compile_system(path).diagnostics
    return ()


def _outline(path: Path, text: str, kind: DocumentKind, data: Any) -> Outline | None:
    if kind is DocumentKind.SSP:
        loaded = load_system(path, DiagnosticBag())
        return outline_loaded(path, loaded.spec.components) if loaded.spec is not None else None
    if kind is DocumentKind.OTHER:
        return None
    outline = outline_yaml(path, text, data)
    if kind is DocumentKind.STUDY and isinstance(outline.data, dict):
        system = outline.data.get("system")
        if isinstance(system, str) and system:
            target = path.parent / system
            system_text = read_text(target, DiagnosticBag()) if target.is_file() else None
            if system_text is not None:
                return Outline(path, outline.data, {}, outline_yaml(target, system_text))
    return outline


def _internal(exc: Exception) -> str:
    """One line about a failure of fmionnx itself: what and where in fmionnx's code."""
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    place = f" ({Path(where.filename).name}:{where.lineno})" if where is not None else ""
    return (
        f"fmionnx could not check this file: internal error {type(exc).__name__}: {exc}{place}; "
        "`fmionnx validate` on the saved file may say more (please report this)"
    )
