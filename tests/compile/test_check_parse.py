"""The check-expression parser: what the grammar accepts, and where it says it stops."""

from __future__ import annotations

import pytest

from fmionnx.compile.checkparse import (
    MAX_DEPTH,
    MAX_LENGTH,
    BinaryOp,
    Call,
    Group,
    Name,
    NumberLit,
    ParseError,
    UnaryOp,
    parse,
)


def test_a_check_is_a_comparison_of_a_call_with_a_number() -> None:
    node = parse("abs(final(tracker.v)) < 0.01")
    assert isinstance(node, BinaryOp)
    assert node.operator == "<"
    assert node.at == 22
    assert isinstance(node.right, NumberLit)
    assert node.right.value == 0.01
    outer = node.left
    assert isinstance(outer, Call)
    assert outer.function == "abs"
    inner = outer.arguments[0].value
    assert isinstance(inner, Call)
    assert inner.function == "final"
    assert inner.arguments[0].value == Name("tracker.v", 10, 19)


def test_keyword_arguments_points_and_paths() -> None:
    node = parse("deviation(a.x, a.y, from=[(0, 0), (3, -1.5e0)])")
    assert isinstance(node, Call)
    keyword = node.arguments[2]
    assert keyword.keyword == "from"
    path = keyword.value
    assert isinstance(path, Group)
    assert path.bracket == "["
    assert len(path.items) == 2
    second = path.items[1]
    assert isinstance(second, Group)
    assert isinstance(second.items[1], UnaryOp)


def test_names_with_indices_and_backticks() -> None:
    node = parse("final(world.base_pos[0]) + final(`plant.der(x)`[1, 2]) > 0")
    assert isinstance(node, BinaryOp)
    assert isinstance(node.left, BinaryOp)
    left, right = node.left.left, node.left.right
    assert isinstance(left, Call)
    assert isinstance(right, Call)
    assert left.arguments[0].value == Name("world.base_pos[0]", 6, 23)
    assert right.arguments[0].value == Name("`plant.der(x)`[1, 2]", 33, 53)


@pytest.mark.parametrize(
    ("text", "tree"),
    [
        ("1 + 2 * 3", "(1 + (2 * 3))"),
        ("1 - 2 - 3", "((1 - 2) - 3)"),
        ("-a.b * 2", "((-a.b) * 2)"),
        ("a.b > 1 and a.c < 2 or not a.d == 0", "(((a.b > 1) and (a.c < 2)) or (not (a.d == 0)))"),
        ("(1 + 2) * 3", "((1 + 2) * 3)"),
    ],
)
def test_precedence(text: str, tree: str) -> None:
    assert _show(parse(text)) == tree


def _show(node: object) -> str:
    match node:
        case NumberLit(value=value):
            return f"{value:g}"
        case Name(text=text):
            return text
        case UnaryOp(operator=operator, operand=operand):
            space = " " if operator == "not" else ""
            return f"({operator}{space}{_show(operand)})"
        case BinaryOp(operator=operator, left=left, right=right):
            return f"({_show(left)} {operator} {_show(right)})"
    raise AssertionError(node)


@pytest.mark.parametrize(
    ("text", "message", "offset"),
    [
        ("final(a.b", "`(` is not closed", 5),
        ("final(a.b c.d)", "expected `,` or `)`, found `c.d`", 10),
        ("0 < a.b < 1", "comparisons do not chain", 8),
        ("final(a.b) = 1", "`=` names an argument inside a call; to compare, write `==`", 11),
        ("final(a.b) && 1", "`&` cannot appear in a check expression", 11),
        ("final(a.b))", "`)` closes nothing", 10),
        ("final(a.b) <", "the expression ends where a value is expected", 12),
        ("final(a.b) < 'x'", "`'` cannot appear in a check expression", 13),
        ("max(`unclosed) < 1", "a name between backticks is not closed", 4),
        ("   ", "the expression is empty", 0),
        ("final(, a.b)", "expected a value, found `,`", 6),
        ("final(a.b) < 1e999", "`1e999` is beyond the range of a number", 13),
    ],
)
def test_syntax_errors_say_what_and_where(text: str, message: str, offset: int) -> None:
    with pytest.raises(ParseError) as caught:
        parse(text)
    assert caught.value.message == message
    assert caught.value.start == offset


def test_too_long_or_too_deep_expressions_are_refused_not_crashed_on() -> None:
    with pytest.raises(ParseError, match="characters long"):
        parse("a.b" + " + a.b" * (MAX_LENGTH // 6 + 1))
    with pytest.raises(ParseError, match="nested more than"):
        parse("(" * 500 + "a.b" + ")" * 500)
    with pytest.raises(ParseError, match="nested more than"):
        parse("-" * 500 + "a.b")
    with pytest.raises(ParseError, match="nested more than"):
        parse(" + ".join(["a.b"] * (MAX_DEPTH + 2)))
    assert isinstance(parse(" + ".join(["a.b"] * (MAX_DEPTH - 2))), BinaryOp)
