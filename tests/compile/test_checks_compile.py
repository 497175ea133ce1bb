"""``checks:`` compiled: resolved trees, and every mistake at the character it concerns."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fmionnx import api
from fmionnx.compile import checkir as ir
from fmionnx.compile.checkparse import ParseError, parse
from fmionnx.compile.systemfile import CompiledFileError, from_json, to_json
from fmionnx.core.diagnostics import Diagnostic
from fmionnx.core.types import PortRef
from fmionnx.reporters.text import format_plain
from tests.conftest import REPO

SCENE = REPO / "models" / "world" / "sign_course.xml"

#: Signals only: compiles without any model file. The expression starts at line 8, column 13.
SYSTEM = """\
fmionnx: 1
name: checked
run: {{stop: 1, step: 0.1}}
components:
  s: {{kind: signal, outputs: {{x: {{constant: 1}}, y: {{constant: 2}}, z3: {{constant: 0}}}}}}
checks:
  - name: probe
    expect: {expect}
"""
EXPRESSION_COLUMN = 13

#: A MuJoCo scene with sites (A and B fixed, `base` on the robot).
WORLD = """\
fmionnx: 1
name: sited
run: {{stop: 1, step: 0.002}}
components:
  world: {{kind: mujoco, path: SCENE}}
checks:
  - name: probe
    expect: {expect}
""".replace("SCENE", SCENE.as_posix())


def _compile(path: Path) -> tuple[object, list[Diagnostic]]:
    result = api.compile_system(path)
    errors = [d for d in result.diagnostics if d.severity.label == "error"]
    return result.system, errors


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _one_error(tmp_path: Path, expect: str, template: str = SYSTEM) -> Diagnostic:
    return _error_of(tmp_path, template.format(expect=expect))


def _error_of(tmp_path: Path, text: str) -> Diagnostic:
    system, errors = _compile(_write(tmp_path, text))
    assert system is None
    assert len(errors) == 1, [str(format_plain(e)) for e in errors]
    return errors[0]


def test_a_check_compiles_to_a_tree_of_columns_and_numbers(tmp_path: Path) -> None:
    path = _write(tmp_path, SYSTEM.format(expect="abs(final(s.x) - 2 * mean(s.y)) <= 0.5"))
    system, errors = _compile(path)
    assert errors == []
    assert system is not None
    (check,) = system.checks  # type: ignore[attr-defined]
    x, y = ir.Signal("s.x", PortRef("s", "x")), ir.Signal("s.y", PortRef("s", "y"))
    assert check == ir.Check(
        name="probe",
        expression="abs(final(s.x) - 2 * mean(s.y)) <= 0.5",
        measure=ir.Unary(
            "abs",
            ir.Binary(
                "-",
                ir.Reduce("final", x),
                ir.Binary("*", ir.Number(2.0), ir.Reduce("mean", y)),
            ),
        ),
        comparison="<=",
        bound=0.5,
        refs=(PortRef("s", "x"), PortRef("s", "y")),
        span=check.span,
    )
    assert check.span is not None
    assert (check.span.line, check.span.col) == (8, EXPRESSION_COLUMN)


@pytest.mark.parametrize(
    ("expect", "code", "offset", "message"),
    [
        ("final(s.q) < 1", "E091", 6, "component `s` (signal) has no port `q`"),
        ("final(q.x) < 1", "E091", 6, "unknown component `q` in `q.x`"),
        ("final(velocity) < 1", "E091", 6, "`velocity` is not a signal"),
        ("fnal(s.x) < 1", "E090", 0, "unknown function `fnal`"),
        ("final(s.x) < final(s.y)", "E093", 13, "the bound (right of the comparison) must be"),
        ("1 > final(s.x)", "E093", 0, "the bound comes after the comparison"),
        ("s.x < 1", "E093", 0, "the measure is a whole signal"),
        ("final(2) < 1", "E093", 6, "`final` takes a signal, not a number"),
        ("first_time(s.x) < 1", "E093", 11, "`first_time` takes a condition"),
        ("max(s.x > 1) < 1", "E093", 4, "`max` takes a signal, not a condition"),
        ("1 < 2", "E093", 0, "the measure reads no signal"),
        ("final(s.x) > 0 and final(s.y) > 0", "E093", 0, "a check compares a measure with"),
        ("final(s.x) < 1 < 2", "E090", 15, "comparisons do not chain"),
        ("final(distance(s.x, to=(1, 2))) < 1", "E093", 6, "takes 2 or 3 coordinates"),
        ("final(distance(s.x, s.y, at=(1, 2))) < 1", "E093", 25, "has no argument `at`"),
        ("final(distance(s.x, s.y)) < 1", "E093", 6, "`distance` needs `to=`"),
        ("final(distance(s.x, s.y, to=(1, 2, 3))) < 1", "E093", 28, "the point has 3"),
        ("final(distance(s.x, s.y, to=s.site.B)) < 1", "E092", 28, "`s` (signal) has no sites"),
        ("final(distance(s.x, s.y, to=s.y)) < 1", "E092", 28, "`s.y` is not a site"),
        ("max(deviation(s.x, s.y, from=[(0, 0)])) < 1", "E093", 29, "at least 2 points"),
        ("max(deviation(s.x, s.y, from=q.expected_path)) < 1", "E092", 29, "unknown component"),
        ("max(deviation(s.x, s.y, from=s.expected_path)) < 1", "E092", 29, "no expected path"),
        ("final(s.expected_path) < 1", "E093", 6, "is a path: it is the `from=`"),
        ("final(not s.x) < 1", "E093", 6, "`not` needs a condition"),
        ("first_time(s.x > 1 and s.y) < 1", "E093", 19, "`and` joins conditions"),
    ],
)
def test_mistakes_are_reported_at_their_character(
    tmp_path: Path, expect: str, code: str, offset: int, message: str
) -> None:
    error = _one_error(tmp_path, expect)
    assert error.code == code
    assert message in error.message
    assert error.message.startswith("check `probe`: ")
    assert error.span is not None
    assert (error.span.line, error.span.col) == (8, EXPRESSION_COLUMN + offset)


def test_an_unknown_function_is_shown_with_the_line_and_a_suggestion(tmp_path: Path) -> None:
    error = _one_error(tmp_path, "abs(fnal(s.x)) < 0.01")
    text = "\n".join(format_plain(error)).replace(str(tmp_path / "system.yaml"), "system.yaml")
    assert text == (
        "system.yaml:8:17: error[E090 check-syntax]: check `probe`: unknown function `fnal`\n"
        "   8 |     expect: abs(fnal(s.x)) < 0.01\n"
        "     |                 ^\n"
        "  hint: did you mean `final`?"
    )


def test_an_unknown_port_lists_the_ports(tmp_path: Path) -> None:
    error = _one_error(tmp_path, "final(s.z4) < 1")
    text = "\n".join(format_plain(error)).replace(str(tmp_path / "system.yaml"), "system.yaml")
    assert text == (
        "system.yaml:8:19: error[E091 check-signal]: check `probe`: component `s` (signal) has "
        "no port `z4`\n"
        "   8 |     expect: final(s.z4) < 1\n"
        "     |                   ^\n"
        "  hint: expected one of `x`, `y`, `z3`"
    )


def test_positions_inside_quoted_and_folded_expressions(tmp_path: Path) -> None:
    quoted = _one_error(tmp_path, "'final(s.q) < 1'")
    assert quoted.span is not None
    assert (quoted.span.line, quoted.span.col) == (8, EXPRESSION_COLUMN + 1 + 6)
    folded = SYSTEM.format(expect="final(distance(s.x, s.y,\n      to=(1, 2, 3))) < 1")
    error = _error_of(tmp_path, folded)
    assert error.span is not None
    assert (error.span.line, error.span.col) == (9, 10)


def test_an_expected_path_next_to_the_model_is_read_at_compile_time(tmp_path: Path) -> None:
    # A signal component's model is the system file: its path file is `system.path.csv`.
    (tmp_path / "system.path.csv").write_text("x,y\n0,0\n3,0\n3,3\n", encoding="utf-8")
    path = _write(
        tmp_path, SYSTEM.format(expect="max(deviation(s.x, s.y, from=s.expected_path)) < 1")
    )
    system, errors = _compile(path)
    assert errors == []
    measure = system.checks[0].measure  # type: ignore[attr-defined]
    assert isinstance(measure, ir.Reduce)
    assert isinstance(measure.series, ir.Deviation)
    assert measure.series.path == ((0.0, 0.0), (3.0, 0.0), (3.0, 3.0))


def test_a_broken_path_file_is_named_with_its_line(tmp_path: Path) -> None:
    (tmp_path / "system.path.csv").write_text("x,y\n0,0\n3,oops\n", encoding="utf-8")
    error = _one_error(tmp_path, "max(deviation(s.x, s.y, from=s.expected_path)) < 1")
    assert error.code == "E092"
    assert "`system.path.csv`:3: `oops` is not a number" in error.message


def test_two_checks_of_one_name_are_an_error_at_the_second(tmp_path: Path) -> None:
    text = SYSTEM.format(expect="final(s.x) < 2") + "  - name: probe\n    expect: final(s.y) < 3\n"
    system, errors = _compile(_write(tmp_path, text))
    assert system is None
    (error,) = errors
    assert error.code == "E094"
    assert error.span is not None
    assert (error.span.line, error.span.col) == (9, 11)
    assert error.notes[0].span is not None
    assert error.notes[0].span.line == 7


def test_a_check_without_a_name_is_named_by_its_expression(tmp_path: Path) -> None:
    text = SYSTEM.format(expect="x").replace(
        "  - name: probe\n    expect: x", "  - expect: final(s.x)  <  2"
    )
    system, errors = _compile(_write(tmp_path, text))
    assert errors == []
    assert system.checks[0].name == "final(s.x) < 2"  # type: ignore[attr-defined]


def test_an_unknown_key_in_a_check_is_a_schema_error(tmp_path: Path) -> None:
    text = SYSTEM.format(expect="final(s.x) < 2") + "    expected: 3\n"
    _, errors = _compile(_write(tmp_path, text))
    assert [e.code for e in errors] == ["E002"]


def test_a_site_is_read_through_the_kind_of_its_component(tmp_path: Path) -> None:
    expect = "final(distance(world.base_pos[0], world.base_pos[1], to=world.site.B)) < 0.5"
    system, errors = _compile(_write(tmp_path, WORLD.format(expect=expect)))
    assert errors == []
    measure = system.checks[0].measure  # type: ignore[attr-defined]
    assert isinstance(measure, ir.Reduce)
    assert isinstance(measure.series, ir.Distance)
    assert measure.series.to == (6.0, 3.0)  # the site's x and y: two coordinates measured
    first = measure.series.coordinates[0]
    assert first == ir.Signal("world.base_pos[0]", PortRef("world", "base_pos", (0,)))
    expect3 = "final(distance(world.base_pos[0], world.base_pos[1], world.base_pos[2], to=world.site.A)) < 1"
    system, errors = _compile(_write(tmp_path, WORLD.format(expect=expect3)))
    assert errors == []
    assert system.checks[0].measure.series.to == (0.0, 0.0, 0.002)  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("site", "message", "hint"),
    [
        ("world.site.C", "`sign_course.xml` has no site `C`", "one of"),
        ("world.site.b", "`sign_course.xml` has no site `b`", "one of `A`, `B`, `base`"),
        ("world.site.base", "site `base` moves with body `base`", "fixed in the world"),
    ],
)
def test_unknown_and_moving_sites_are_refused(
    tmp_path: Path, site: str, message: str, hint: str
) -> None:
    expect = f"final(distance(world.base_pos[0], world.base_pos[1], to={site})) < 0.5"
    error = _one_error(tmp_path, expect, WORLD)
    assert error.code == "E092"
    assert message in error.message
    assert error.hint is not None
    assert hint in error.hint
    assert error.span is not None
    assert error.span.col == EXPRESSION_COLUMN + expect.index(site)


def test_whole_arrays_and_images_are_not_measured(tmp_path: Path) -> None:
    error = _one_error(tmp_path, "final(world.base_pos) < 1", WORLD)
    assert error.code == "E091"
    assert "is an array of shape [3]; a check reads one element" in error.message
    assert error.hint == "pick an element: `world.base_pos[0]`"


def test_checks_travel_in_the_compiled_system_file(tmp_path: Path) -> None:
    expect = (
        "first_time(not (s.x > 2 or s.y < -1) and abs(s.x) >= 0.5) + "
        "max(deviation(s.x, s.y, from=[(0, 0), (1, 1.5)])) / 2 != 3"
    )
    system, errors = _compile(_write(tmp_path, SYSTEM.format(expect=expect)))
    assert errors == []
    text = to_json(system)  # type: ignore[arg-type]
    back = from_json(text)
    assert back == system
    assert back.checks[0].measure == system.checks[0].measure  # type: ignore[attr-defined]
    assert to_json(back) == text


def test_a_hand_edited_check_tree_is_refused_with_where(tmp_path: Path) -> None:
    system, _ = _compile(_write(tmp_path, SYSTEM.format(expect="final(s.x) < 2")))
    text = to_json(system)  # type: ignore[arg-type]
    with pytest.raises(CompiledFileError, match=r"system\.checks\[0\]\.comparison"):
        from_json(text.replace('"comparison": "<"', '"comparison": "<<"'))
    document = json.loads(text)
    node: dict[str, object] = {"value": 1.0}
    for _ in range(400):  # far deeper than the compiler makes (64), within what JSON reads
        node = {"unary": "-", "operand": node}
    document["system"]["checks"][0]["measure"] = node
    with pytest.raises(CompiledFileError, match="nested too deeply"):
        from_json(json.dumps(document))


FRAGMENTS = [
    *("final(", "max(", "mean(", "first_time(", "abs(", "distance(", "deviation(", "fnal("),
    *("s.x", "s.y", "s.z3", "s.q", "time", "s.site.B", "s.expected_path", "`s.x`", "s.x[0]"),
    *("(", ")", "[", "]", ",", "to=", "from=", "=", "<", ">=", "==", "+", "-", "*", "/"),
    *("and ", "or ", "not ", "0.5", "-1", "1e999", " ", "`", "'", "\\n", "(1, 2)"),
]


@given(st.lists(st.sampled_from(FRAGMENTS), max_size=14))
@settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_any_expression_ends_in_a_check_or_a_located_diagnostic(
    tmp_path: Path, fragments: list[str]
) -> None:
    expect = "".join(fragments) or "x"
    text = SYSTEM.format(expect=json.dumps(expect))  # a JSON string is a YAML scalar
    system, errors = _compile(_write(tmp_path, text))
    if system is None:
        assert errors
        for error in errors:
            assert error.span is not None
            assert error.span.line >= 7
            assert error.message
    else:
        assert len(system.checks) == 1  # type: ignore[attr-defined]


@given(st.text(max_size=60))
@settings(max_examples=300, deadline=None)
def test_the_parser_answers_any_text_with_a_tree_or_a_parse_error(text: str) -> None:
    start = 0
    try:
        parse(text)
    except ParseError as exc:
        start = exc.start
    assert 0 <= start <= len(text)
