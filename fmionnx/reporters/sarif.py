"""``--format sarif``: SARIF 2.1.0 for code-scanning dashboards (GitHub code scanning ...).

One run holds every system file's results. ``tool.driver.rules`` is the whole code table
(:data:`fmionnx.core.diagnostics.CODES`), so a dashboard can show a rule's description even for
codes that did not fire; results point at their rule by ``ruleId`` and ``ruleIndex``.
Locations are relative to the working directory, named by the ``%SRCROOT%`` base id, which
is how GitHub's upload action resolves them against the checkout.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TextIO
from urllib.parse import quote

from fmionnx import __version__
from fmionnx.core.diagnostics import CODES, Diagnostic, Severity, Span
from fmionnx.reporters.base import FileResult, Reporter
from fmionnx.reporters.common import display_path, full_text, located
from fmionnx.reporters.json_report import JsonValue

SARIF_SCHEMA = (
    "https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/sarif-schema-2.1.0.json"
)
SRCROOT = "%SRCROOT%"

_LEVEL = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.INFO: "note"}
_RULE_INDEX = {code: index for index, code in enumerate(CODES)}


def rules() -> list[JsonValue]:
    """``reportingDescriptor`` objects for every diagnostic code, in table order."""
    return [
        {
            "id": entry.code,
            "name": entry.name,
            "shortDescription": {"text": entry.description},
            "defaultConfiguration": {"level": _LEVEL[entry.severity]},
            "properties": {"category": entry.category},
        }
        for entry in CODES.values()
    ]


def artifact_location(path: Path) -> dict[str, JsonValue]:
    """A percent-encoded URI relative to ``%SRCROOT%``, or a ``file:`` URI outside it."""
    shown = display_path(path)
    if Path(shown).is_absolute():
        return {"uri": Path(shown).as_uri()}
    return {"uri": quote(shown), "uriBaseId": SRCROOT}


def _location(span: Span, message: str | None = None) -> dict[str, JsonValue]:
    physical: dict[str, JsonValue] = {"artifactLocation": artifact_location(span.file)}
    if span.line > 0:
        region: dict[str, JsonValue] = {"startLine": span.line}
        if span.col > 0:
            region["startColumn"] = span.col
        physical["region"] = region
    location: dict[str, JsonValue] = {"physicalLocation": physical}
    if message is not None:
        location["message"] = {"text": message}
    return location


def result_json(diagnostic: Diagnostic, result: FileResult) -> dict[str, JsonValue]:
    """One SARIF ``result``; notes with a location also become ``relatedLocations``."""
    sarif: dict[str, JsonValue] = {
        "ruleId": diagnostic.code,
        "ruleIndex": _RULE_INDEX[diagnostic.code],
        "level": _LEVEL[diagnostic.severity],
        "message": {"text": full_text(diagnostic)},
        "locations": [_location(located(diagnostic, result.path))],
    }
    related: list[JsonValue] = []
    for note in diagnostic.notes:
        if note.span is not None:
            related_location = _location(note.span, note.message)
            related_location["id"] = len(related)
            related.append(related_location)
    if related:
        sarif["relatedLocations"] = related
    return sarif


def sarif_json(results: list[FileResult]) -> dict[str, JsonValue]:
    """The SARIF log of a validate call."""
    return {
        "$schema": SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "fmionnx",
                        "version": __version__,
                        "rules": rules(),
                    }
                },
                "results": [result_json(d, r) for r in results for d in r.diagnostics],
                "columnKind": "unicodeCodePoints",
            }
        ],
    }


class SarifReporter(Reporter):
    """SARIF 2.1.0 log on the stream."""

    name = "sarif"

    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write the SARIF log as indented JSON (``color`` is ignored)."""
        del color
        stream.write(json.dumps(sarif_json(results), indent=2, ensure_ascii=False) + "\n")
