from __future__ import annotations

import io
import xml.etree.ElementTree as ET
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span, make
from fmionnx.reporters import REPORTER_BY_NAME, FileResult
from fmionnx.reporters.junit import CHECKS


def parse(results: list[FileResult]) -> ET.Element:
    out = io.StringIO()
    REPORTER_BY_NAME["junit"].render(results, out, color=False)
    return ET.fromstring(out.getvalue().encode())


def test_one_suite_per_file_and_one_case_per_check(two_files: list[FileResult]) -> None:
    root = parse(two_files)
    suites = root.findall("testsuite")
    assert [s.get("name") for s in suites] == ["a.yaml", "sub/b.yaml"]
    for suite in suites:
        assert [c.get("name") for c in suite.findall("testcase")] == list(CHECKS)
        assert suite.get("tests") == str(len(CHECKS))
    assert root.get("tests") == str(2 * len(CHECKS))


def test_errors_fail_their_check_warnings_go_to_system_out(two_files: list[FileResult]) -> None:
    root = parse(two_files)
    a, b = root.findall("testsuite")
    failed_a = {c.get("name") for c in a.iter("testcase") if c.find("failure") is not None}
    failed_b = {c.get("name") for c in b.iter("testcase") if c.find("failure") is not None}
    assert failed_a == {"connection"}
    assert failed_b == {"endpoint", "model"}
    assert a.get("failures") == "1"
    assert b.get("failures") == "2"
    assert root.get("failures") == "3"
    connection = a.find("testcase[@name='connection']")
    assert connection is not None
    failure = connection.find("failure")
    assert failure is not None
    assert failure.get("type") == "E031"
    assert failure.text is not None
    assert failure.text.startswith("a.yaml:7:5: error[E031 dtype]: cannot connect")
    assert "  hint: connect a numeric output" in failure.text
    out = connection.find("system-out")
    assert out is not None
    assert out.text is not None
    assert "warning[W030 unconnected-input]" in out.text


def test_lock_check_is_skipped_unless_locked(tmp_path: Path) -> None:
    info = make(codes.LOCK_BINARY_CHANGED, "binary changed", Span(tmp_path / "s.yaml", 3, 3))
    unlocked = parse([FileResult(tmp_path / "s.yaml", (), document="study")])
    locked = parse([FileResult(tmp_path / "s.yaml", (info,), locked=True, document="study")])
    assert unlocked.find("testsuite/testcase[@name='lock']/skipped") is not None
    assert unlocked.get("skipped") == "1"
    lock_case = locked.find("testsuite/testcase[@name='lock']")
    assert lock_case is not None
    assert lock_case.find("skipped") is None
    assert lock_case.find("failure") is None
    assert locked.get("skipped") == "0"


def test_characters_xml_cannot_carry_are_replaced(tmp_path: Path) -> None:
    bad = make(codes.SYNTAX, "invalid YAML: found \x07 character", Span(tmp_path / "s.yaml", 1, 1))
    root = parse([FileResult(tmp_path / "s.yaml", (bad,))])
    failure = root.find("testsuite/testcase[@name='syntax']/failure")
    assert failure is not None
    assert failure.get("message") == "invalid YAML: found \ufffd character"
