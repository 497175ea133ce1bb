"""A check's numbers are the grammar's: ASCII digits and one sign at most (a bug hunt found
``final(s.x) > \\u0661``, an Arabic-Indic digit Python's ``float`` reads, and ``> +-1`` accepted).
Refused as check-syntax errors (E090) at the character concerned."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.compile.checkparse import BinaryOp, ParseError, parse

#: Signals only: compiles without any model file. The expression starts at line 7, column 13.
SYSTEM = """\
fmionnx: 1
name: checked
run: {{stop: 1, step: 0.1}}
components:
  s: {{kind: signal, outputs: {{x: {{constant: 1}}}}}}
checks:
  - expect: {expect}
"""
EXPRESSION_COLUMN = 13


@pytest.mark.parametrize(
    ("expect", "offset", "message"),
    [
        ("final(s.x) > \u0661", 13, "`\u0661` cannot appear in a check expression"),
        ("final(s.x) > 1\u0660", 14, "`\u0660` cannot appear in a check expression"),
        ("final(s.x[\u0660]) > 1", 10, "`\u0660` cannot appear in a check expression"),
        ("final(s.x) > +-1", 13, "`+-1` is not a number: a number has one sign at most"),
        ("final(s.x) > - -1", 13, "`--1` is not a number: a number has one sign at most"),
        ("final(s.x) * --2 > 1", 13, "`--2` is not a number: a number has one sign at most"),
    ],
)
def test_a_malformed_number_is_a_syntax_error_at_its_place(
    tmp_path: Path, expect: str, offset: int, message: str
) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(expect=expect), encoding="utf-8")
    result = api.compile_system(path)
    errors = [d for d in result.diagnostics if d.severity.label == "error"]
    assert result.system is None
    assert [(e.code, e.span.line, e.span.col) for e in errors] == [
        ("E090", 7, EXPRESSION_COLUMN + offset)
    ]
    assert errors[0].message == f"check `{expect}`: {message}"


def test_the_hints_say_how_to_write_the_number() -> None:
    with pytest.raises(ParseError) as caught:
        parse("final(s.x) > \u0661")
    assert caught.value.hint == "write numbers and indices with the digits 0-9"
    with pytest.raises(ParseError) as caught:
        parse("final(s.x) > +-1")
    assert caught.value.hint == "write `-1`"
    with pytest.raises(ParseError) as caught:
        parse("final(s.x) > --1")
    assert caught.value.hint == "write `1`"


@pytest.mark.parametrize(
    "text", ["final(s.x) > -1", "final(s.x) > +1.5e-3", "final(s.x) - -1 > 0", "--s.x < 1"]
)
def test_one_sign_and_signs_before_a_measure_still_parse(text: str) -> None:
    assert isinstance(parse(text), BinaryOp)
