"""Diagnostics are data: a stable code table, source spans, and collected findings.

Every user-facing problem (bad YAML, a missing file, a type mismatch, a cycle) becomes a
:class:`Diagnostic` with a code from :data:`CODES`, a severity, a message, a :class:`Span` in
the file the user wrote, optional notes pointing into model files, and a hint. Stages collect
them into a :class:`DiagnosticBag` instead of raising, so one run reports every problem.
Rendering lives in :mod:`fmionnx.report`.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core.codes import CODES, ErrorCode, Severity
from fmionnx.core.pathnames import shown


@dataclass(frozen=True, slots=True)
class Span:
    """A position in a source file: 1-based line and column; 0 means "whole file"."""

    file: Path
    line: int = 0
    col: int = 0

    def __str__(self) -> str:
        name = shown(self.file)
        if self.line <= 0:
            return name
        if self.col <= 0:
            return f"{name}:{self.line}"
        return f"{name}:{self.line}:{self.col}"


@dataclass(frozen=True, slots=True)
class Note:
    """A secondary location, e.g. ``modelDescription.xml:42`` where a variable is declared."""

    message: str
    span: Span | None = None


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One finding. ``code`` is a key of :data:`CODES`; severity defaults to the code's."""

    code: str
    message: str
    span: Span | None = None
    hint: str | None = None
    notes: tuple[Note, ...] = ()
    severity: Severity = field(default=Severity.ERROR)

    @property
    def name(self) -> str:
        """The code's symbolic name (``dtype``, ``unknown-port`` ...)."""
        return CODES[self.code].name

    def sort_key(self) -> tuple[str, int, int, str, str]:
        """Order by file, line, column, then code, so output is stable."""
        span = self.span
        if span is None:
            return ("", 0, 0, self.code, self.message)
        return (str(span.file), span.line, span.col, self.code, self.message)


def make(
    code: ErrorCode,
    message: str,
    span: Span | None = None,
    *,
    hint: str | None = None,
    notes: Iterable[Note] = (),
) -> Diagnostic:
    """Build a diagnostic with the code's severity."""
    return Diagnostic(
        code=code.code,
        message=message,
        span=span,
        hint=hint,
        notes=tuple(notes),
        severity=code.severity,
    )


class DiagnosticBag:
    """Collects diagnostics across stages; never raises for user mistakes."""

    def __init__(self) -> None:
        self._items: list[Diagnostic] = []

    def add(self, diagnostic: Diagnostic) -> None:
        """Record one diagnostic."""
        self._items.append(diagnostic)

    def emit(
        self,
        code: ErrorCode,
        message: str,
        span: Span | None = None,
        *,
        hint: str | None = None,
        notes: Iterable[Note] = (),
    ) -> Diagnostic:
        """Build (with :func:`make`) and record a diagnostic; returns it."""
        diagnostic = make(code, message, span, hint=hint, notes=notes)
        self._items.append(diagnostic)
        return diagnostic

    def extend(self, diagnostics: Iterable[Diagnostic]) -> None:
        """Record several diagnostics."""
        self._items.extend(diagnostics)

    @property
    def has_errors(self) -> bool:
        """True when at least one error was recorded."""
        return any(d.severity is Severity.ERROR for d in self._items)

    def sorted(self) -> list[Diagnostic]:
        """All diagnostics, deduplicated and in stable order."""
        unique = dict.fromkeys(self._items)
        return sorted(unique, key=Diagnostic.sort_key)

    def __iter__(self) -> Iterator[Diagnostic]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)


def with_article(noun: str) -> str:
    """``noun`` after its indefinite article, by its sound: "an input", "an actuator", "an
    RGB image", "a uint8", "a jointpos sensor" (one rule for every message that needs one)."""
    vowel_sound = (noun[:1].lower() in "aeio" and not noun.startswith("one")) or (
        noun[:1].lower() == "u" and not noun.startswith(("uint", "uni", "us"))
    )
    return ("an " if vowel_sound or noun.startswith("RGB") else "a ") + noun


def did_you_mean(word: str, candidates: Iterable[str]) -> str | None:
    """A ``did you mean `x`?`` hint for the closest candidate, or None when nothing is close."""
    matches = difflib.get_close_matches(word, list(candidates), n=1, cutoff=0.6)
    if not matches:
        return None
    return f"did you mean `{matches[0]}`?"


def one_of(candidates: Iterable[str], limit: int = 12) -> str:
    """Render the valid choices for a hint: ``expected one of `a`, `b`, `c```."""
    names = sorted(set(candidates))
    shown = ", ".join(f"`{n}`" for n in names[:limit])
    more = f" (and {len(names) - limit} more)" if len(names) > limit else ""
    return f"expected one of {shown}{more}" if names else "there are none"


__all__ = [
    "CODES",
    "Diagnostic",
    "DiagnosticBag",
    "ErrorCode",
    "Note",
    "Severity",
    "Span",
    "did_you_mean",
    "make",
    "one_of",
]
