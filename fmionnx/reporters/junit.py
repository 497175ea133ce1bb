"""``--format junit``: JUnit XML for the test tabs of CI systems (GitLab, Jenkins, Azure ...).

A *check* is one category of the code table (``syntax``, ``schema``, ``model``, ``endpoint``,
``connection``, ``graph``, ``run``, ``parameter``, ``ros2``, ``ssp``, ``lock``). Every system
file becomes one ``<testsuite>`` holding one ``<testcase>`` per check, always the same list,
so CI trend views can follow a check across runs. A check fails when it produced an error;
its ``<failure>`` carries every error of the category in text form. Warnings and infos do not
fail a check: they go to the test case's ``<system-out>``. The ``lock`` check is skipped
unless ``--locked`` was given, the ``study`` check unless the file is a study.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from typing import TextIO

from fmionnx.core.diagnostics import CODES, Diagnostic, Severity
from fmionnx.reporters.base import FileResult, Reporter
from fmionnx.reporters.common import detail_lines, display_path, located

#: The checks, in code-table order.
CHECKS: tuple[str, ...] = tuple(dict.fromkeys(entry.category for entry in CODES.values()))

#: Characters XML 1.0 cannot carry, even escaped; replaced so a stray byte in a user's file
#: cannot make the report unreadable.
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _clean(text: str) -> str:
    return _NOT_XML.sub("\ufffd", text)


def _line(diagnostic: Diagnostic, result: FileResult) -> str:
    span = located(diagnostic, result.path)
    where = display_path(span.file)
    if span.line > 0:
        where += f":{span.line}" + (f":{span.col}" if span.col > 0 else "")
    head = (
        f"{where}: {diagnostic.severity.label}[{diagnostic.code} {diagnostic.name}]: "
        f"{diagnostic.message}"
    )
    return "\n".join([head, *("  " + line for line in detail_lines(diagnostic))])


def _testcase(check: str, result: FileResult, name: str) -> tuple[ET.Element, str]:
    """One test case and its outcome (``passed``, ``failed`` or ``skipped``)."""
    case = ET.Element("testcase", {"name": check, "classname": name, "file": name, "time": "0"})
    mine = [d for d in result.diagnostics if CODES[d.code].category == check]
    errors = [d for d in mine if d.severity is Severity.ERROR]
    others = [d for d in mine if d.severity is not Severity.ERROR]
    outcome = "passed"
    if errors:
        first = errors[0].message
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        failure = ET.SubElement(
            case, "failure", {"type": errors[0].code, "message": _clean(first + more)}
        )
        failure.text = _clean("\n".join(_line(d, result) for d in errors)) + "\n"
        outcome = "failed"
    elif check == "lock" and not result.locked:
        ET.SubElement(case, "skipped", {"message": "interface lock not checked (use --locked)"})
        outcome = "skipped"
    elif check == "study" and result.document != "study":
        ET.SubElement(case, "skipped", {"message": f"not a study file (a {result.document})"})
        outcome = "skipped"
    if others:
        out = ET.SubElement(case, "system-out")
        out.text = _clean("\n".join(_line(d, result) for d in others)) + "\n"
    return case, outcome


def junit_tree(results: list[FileResult]) -> ET.Element:
    """The ``<testsuites>`` element of a validate call."""
    root = ET.Element("testsuites", {"name": "fmionnx validate"})
    totals = {"tests": 0, "failures": 0, "skipped": 0}
    for result in results:
        name = display_path(result.path)
        suite = ET.SubElement(root, "testsuite", {"name": name})
        outcomes = []
        for check in CHECKS:
            case, outcome = _testcase(check, result, name)
            suite.append(case)
            outcomes.append(outcome)
        counts = {
            "tests": len(outcomes),
            "failures": outcomes.count("failed"),
            "skipped": outcomes.count("skipped"),
        }
        for key, value in counts.items():
            totals[key] += value
        suite.attrib.update({key: str(value) for key, value in counts.items()})
        suite.attrib.update({"errors": "0", "time": "0"})
    root.attrib.update({key: str(value) for key, value in totals.items()})
    root.attrib.update({"errors": "0", "time": "0"})
    return root


class JunitReporter(Reporter):
    """JUnit XML on the stream."""

    name = "junit"

    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write the XML document (``color`` is ignored)."""
        del color
        root = junit_tree(results)
        ET.indent(root)
        stream.write('<?xml version="1.0" encoding="UTF-8"?>\n')
        stream.write(ET.tostring(root, encoding="unicode") + "\n")
