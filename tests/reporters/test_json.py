from __future__ import annotations

import io
import json
from importlib import resources
from typing import Any

import jsonschema

from fmionnx.reporters import REPORTER_BY_NAME, FileResult


def render(results: list[FileResult]) -> Any:
    out = io.StringIO()
    REPORTER_BY_NAME["json"].render(results, out, color=True)
    return json.loads(out.getvalue())


def schema() -> Any:
    text = resources.files("fmionnx.reporters").joinpath("report.schema.json").read_text("utf-8")
    return json.loads(text)


def test_json_report_validates_against_its_published_schema(two_files: list[FileResult]) -> None:
    jsonschema.Draft202012Validator(schema()).validate(render(two_files))


def test_schema_rejects_a_report_without_version() -> None:
    report = {"tool": {"name": "fmionnx", "version": "0"}, "files": [], "summary": {}}
    assert not jsonschema.Draft202012Validator(schema()).is_valid(report)


def test_json_report_has_files_diagnostics_and_summary(two_files: list[FileResult]) -> None:
    report = render(two_files)
    assert report["version"] == 1
    assert [f["path"] for f in report["files"]] == ["a.yaml", "sub/b.yaml"]
    first = report["files"][0]["diagnostics"][0]
    assert first == {
        "code": "E031",
        "name": "dtype",
        "severity": "error",
        "message": "cannot connect `net.label_out` (string) to `gain.u` (float64)",
        "file": "a.yaml",
        "line": 7,
        "col": 5,
        "hint": "connect a numeric output",
        "notes": [
            {
                "message": "`u` is declared here",
                "file": "models/modelDescription.xml",
                "line": 36,
                "col": 12,
            }
        ],
    }
    no_span = report["files"][1]["diagnostics"][1]
    assert (no_span["file"], no_span["line"], no_span["col"]) == (None, None, None)
    assert report["files"][1]["ok"] is False
    assert report["summary"] == {"files": 2, "ok": False, "errors": 3, "warnings": 1, "infos": 1}
