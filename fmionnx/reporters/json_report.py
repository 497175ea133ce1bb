"""``--format json``: one JSON document, schema ``report.schema.json`` (version 1).

The schema is a promise to scripts: fields are only ever added within a version; renaming or
removing one bumps ``version``. Lines and columns are 1-based, ``null`` when unknown.
"""

from __future__ import annotations

import json
from typing import TextIO

from fmionnx import __version__
from fmionnx.core.diagnostics import Diagnostic, Note, Severity, Span
from fmionnx.reporters.base import FileResult, Reporter, count
from fmionnx.reporters.common import display_path

#: Version of the report layout (not of fmionnx).
REPORT_VERSION = 1

JsonValue = str | int | bool | None | list["JsonValue"] | dict[str, "JsonValue"]


def _where(span: Span | None) -> dict[str, JsonValue]:
    if span is None:
        return {"file": None, "line": None, "col": None}
    return {
        "file": display_path(span.file),
        "line": span.line if span.line > 0 else None,
        "col": span.col if span.line > 0 and span.col > 0 else None,
    }


def _note(note: Note) -> dict[str, JsonValue]:
    return {"message": note.message, **_where(note.span)}


def diagnostic_json(diagnostic: Diagnostic) -> dict[str, JsonValue]:
    """One diagnostic as a JSON object."""
    return {
        "code": diagnostic.code,
        "name": diagnostic.name,
        "severity": diagnostic.severity.label,
        "message": diagnostic.message,
        **_where(diagnostic.span),
        "hint": diagnostic.hint,
        "notes": [_note(n) for n in diagnostic.notes],
    }


def _counts(results: list[FileResult]) -> dict[str, JsonValue]:
    return {
        "errors": count(results, Severity.ERROR),
        "warnings": count(results, Severity.WARNING),
        "infos": count(results, Severity.INFO),
    }


def report_json(results: list[FileResult]) -> dict[str, JsonValue]:
    """The whole report as a JSON-ready dict."""
    files: list[JsonValue] = [
        {
            "path": display_path(r.path),
            "ok": r.worst is not Severity.ERROR,
            **_counts([r]),
            "diagnostics": [diagnostic_json(d) for d in r.diagnostics],
        }
        for r in results
    ]
    errors = count(results, Severity.ERROR)
    return {
        "version": REPORT_VERSION,
        "tool": {"name": "fmionnx", "version": __version__},
        "files": files,
        "summary": {"files": len(results), "ok": errors == 0, **_counts(results)},
    }


class JsonReporter(Reporter):
    """Machine-readable report for scripts and dashboards."""

    name = "json"

    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write the report as indented JSON and a final newline (``color`` is ignored)."""
        del color
        stream.write(json.dumps(report_json(results), indent=2, ensure_ascii=False) + "\n")
