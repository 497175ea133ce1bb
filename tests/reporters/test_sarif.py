from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from fmionnx.core.diagnostics import CODES
from fmionnx.reporters import REPORTER_BY_NAME, FileResult

SCHEMA = json.loads((Path(__file__).parent / "sarif-schema-2.1.0.json").read_text(encoding="utf-8"))


def render(results: list[FileResult]) -> Any:
    out = io.StringIO()
    REPORTER_BY_NAME["sarif"].render(results, out, color=False)
    return json.loads(out.getvalue())


def test_sarif_log_validates_against_the_sarif_2_1_0_schema(two_files: list[FileResult]) -> None:
    log = render(two_files)
    jsonschema.Draft4Validator(SCHEMA, format_checker=jsonschema.FormatChecker()).validate(log)


def test_empty_sarif_log_validates(two_files: list[FileResult]) -> None:
    jsonschema.Draft4Validator(SCHEMA).validate(render([]))


def test_a_bad_log_fails_the_schema_so_the_check_can_fail() -> None:
    bad = {"version": "2.1.0", "runs": [{"tool": {"driver": {}}}]}
    assert not jsonschema.Draft4Validator(SCHEMA).is_valid(bad)


def test_driver_rules_are_the_code_table(two_files: list[FileResult]) -> None:
    driver = render(two_files)["runs"][0]["tool"]["driver"]
    assert [r["id"] for r in driver["rules"]] == list(CODES)
    e031 = driver["rules"][list(CODES).index("E031")]
    assert e031["name"] == "dtype"
    assert e031["defaultConfiguration"]["level"] == "error"


def test_results_point_at_rules_and_relative_locations(two_files: list[FileResult]) -> None:
    log = render(two_files)
    run = log["runs"][0]
    results = run["results"]
    assert [r["ruleId"] for r in results] == ["E031", "W030", "E021", "E010", "I080"]
    assert [r["level"] for r in results] == ["error", "warning", "error", "error", "note"]
    for result in results:
        assert run["tool"]["driver"]["rules"][result["ruleIndex"]]["id"] == result["ruleId"]
    first = results[0]["locations"][0]["physicalLocation"]
    assert first == {
        "artifactLocation": {"uri": "a.yaml", "uriBaseId": "%SRCROOT%"},
        "region": {"startLine": 7, "startColumn": 5},
    }
    related = results[0]["relatedLocations"][0]
    assert related["physicalLocation"]["artifactLocation"]["uri"] == "models/modelDescription.xml"
    assert related["message"]["text"] == "`u` is declared here"
    no_span = results[3]["locations"][0]["physicalLocation"]
    assert no_span == {"artifactLocation": {"uri": "sub/b.yaml", "uriBaseId": "%SRCROOT%"}}


def test_uris_are_percent_encoded_and_absolute_outside_the_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from fmionnx.reporters.sarif import artifact_location

    monkeypatch.chdir(tmp_path)
    assert artifact_location(tmp_path / "my systems" / "a.yaml") == {
        "uri": "my%20systems/a.yaml",
        "uriBaseId": "%SRCROOT%",
    }
    outside = tmp_path.parent / "models" / "m.xml"
    assert artifact_location(outside) == {"uri": outside.as_uri()}
