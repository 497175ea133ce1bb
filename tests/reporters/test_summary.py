"""The text report's last line counts the files its problems are in.

A study's errors in its system file said "in 1 file" (the one file checked); a bug hunt read
that as a wrong count.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span, make
from fmionnx.reporters.base import FileResult
from fmionnx.reporters.text import summary

STUDY = Path("study.yaml")
SYSTEM = Path("system.yaml")


def test_problems_in_the_study_and_its_system_are_in_two_files() -> None:
    found = (
        make(codes.UNKNOWN_PORT, "no port `zz`", Span(SYSTEM, 5, 3)),
        make(codes.STUDY_SYSTEM, "the system does not compile", Span(STUDY, 2, 9)),
    )
    assert summary([FileResult(STUDY, found)]) == "2 errors in 2 files"


def test_files_checked_without_a_problem_are_counted_apart() -> None:
    found = (make(codes.UNCONNECTED_INPUT, "input `g.v` is not connected", Span(SYSTEM, 5, 3)),)
    results = [FileResult(SYSTEM, found), FileResult(STUDY, ()), FileResult(Path("c.yaml"), ())]
    assert summary(results) == "1 warning in 1 file (3 checked)"


def test_a_problem_without_a_place_is_in_its_checked_file() -> None:
    found = (make(codes.FILE_NOT_FOUND, "no such file", None),)
    assert summary([FileResult(SYSTEM, found)]) == "1 error in 1 file"
    assert summary([FileResult(SYSTEM, ()), FileResult(STUDY, ())]) == "no problems in 2 files"
