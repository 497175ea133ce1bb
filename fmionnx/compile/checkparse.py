"""The check-expression language: text -> syntax tree with character offsets.

A small hand-written recursive-descent parser (never ``eval``): the grammar is the whole
language, so nothing outside it can be written, and every error names the offset it found
it at (the compiler turns offsets into ``file:line:col``). The grammar, from loosest to
tightest binding (docs/checks.md)::

    expr       := or
    or         := and ("or" and)*
    and        := not ("and" not)*
    not        := "not" not | comparison
    comparison := sum (("<" | "<=" | ">" | ">=" | "==" | "!=") sum)?
    sum        := term (("+" | "-") term)*
    term       := unary (("*" | "/") unary)*
    unary      := ("-" | "+") unary | primary
    primary    := NUMBER | NAME | NAME "(" [argument ("," argument)*] ")"
                | "(" expr ("," expr)* ")" | "[" expr ("," expr)* "]"
    argument   := [IDENT "="] expr

A NAME is a dotted name with an optional element index (``odometry.posX``,
``world.base_pos[0]``, ``world.site.B``) or any text between backticks
(`` `plant.der(x)` ``). Comparisons do not chain (``a < b < c`` is an error, not Python's
meaning); a tuple ``(x, y)`` is a point and a list of points a path.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

#: Longest expression accepted; a check is one line of meaning, not a program.
MAX_LENGTH = 2000
#: Deepest nesting of the syntax tree (parentheses, calls, operator chains): evaluating and
#: serialising a tree recurse over it.
MAX_DEPTH = 64

COMPARISONS = ("<=", ">=", "==", "!=", "<", ">")
KEYWORDS = ("and", "or", "not")

#: Digits are ASCII ``[0-9]``, not ``\d``: ``\d`` also matches other scripts' digits
#: (``\u0661``, which ``float`` reads as 1), which the grammar does not have (a bug hunt).
_TOKEN = re.compile(
    r"""
    (?P<space>\s+)
  | (?P<number>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)
  | (?P<name>[A-Za-z_$][\w$]*(?:\.[A-Za-z_$][\w$]*)*(?:\[\s*[0-9]+\s*(?:,\s*[0-9]+\s*)*\])?)
  | (?P<quoted>`[^`]*`(?:\[\s*[0-9]+\s*(?:,\s*[0-9]+\s*)*\])?)
  | (?P<operator><=|>=|==|!=|[-+*/<>=(),\[\]])
    """,
    re.VERBOSE,
)


class ParseError(Exception):
    """A check expression that does not follow the grammar, at ``start`` (a text offset)."""

    def __init__(self, message: str, start: int, hint: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.start = start
        self.hint = hint


@dataclass(frozen=True, slots=True)
class Token:
    """One token: its kind (``number``, ``name``, ``quoted``, ``operator``, ``end``), text and
    offset in the expression."""

    kind: str
    text: str
    start: int


# -- the syntax tree: what was written, with where -------------------------------------------


@dataclass(frozen=True, slots=True)
class NumberLit:
    """A number as written."""

    value: float
    start: int
    end: int


@dataclass(frozen=True, slots=True)
class Name:
    """A name: a signal, ``time``, a site or an expected path (decided by the compiler)."""

    text: str
    start: int
    end: int


@dataclass(frozen=True, slots=True)
class Argument:
    """One argument of a call, positional or ``keyword=value``."""

    keyword: str | None
    value: Node
    start: int


@dataclass(frozen=True, slots=True)
class Call:
    """``function(arguments)``."""

    function: str
    arguments: tuple[Argument, ...]
    start: int
    end: int


@dataclass(frozen=True, slots=True)
class UnaryOp:
    """``-x``, ``+x`` or ``not c``."""

    operator: str
    operand: Node
    start: int
    end: int


@dataclass(frozen=True, slots=True)
class BinaryOp:
    """``left <operator> right``; ``at`` is the operator's offset."""

    operator: str
    left: Node
    right: Node
    at: int
    start: int
    end: int


@dataclass(frozen=True, slots=True)
class Group:
    """``(a, b, ...)`` (a point) or ``[a, b, ...]`` (a path), by ``bracket``."""

    bracket: str
    items: tuple[Node, ...]
    start: int
    end: int


Node = NumberLit | Name | Call | UnaryOp | BinaryOp | Group
_Rule = Callable[[], Node]


def tokenize(text: str) -> list[Token]:
    """The tokens of ``text``, ending with an ``end`` token; ParseError at a stray character."""
    tokens = []
    position = 0
    while position < len(text):
        match = _TOKEN.match(text, position)
        if match is None or match.end() == position:
            char = text[position]
            if char == "`":
                raise ParseError("a name between backticks is not closed", position, "add a `")
            hint = None
            if char in "'\"":
                hint = "names are written without quotes (or between backticks)"
            elif char in {"&", "|"}:
                hint = "write `and` / `or`"
            elif char == "!":
                hint = "write `not` for a negation, `!=` for 'differs'"
            elif char.isdigit():
                hint = "write numbers and indices with the digits 0-9"
            raise ParseError(f"`{char}` cannot appear in a check expression", position, hint)
        kind = match.lastgroup or "space"
        if kind != "space":
            tokens.append(Token(kind, match.group(), position))
        position = match.end()
    tokens.append(Token("end", "", len(text)))
    return tokens


def parse(text: str) -> Node:
    """The syntax tree of a check expression; ParseError says what is wrong and where."""
    if len(text) > MAX_LENGTH:
        raise ParseError(
            f"the expression is {len(text)} characters long; at most {MAX_LENGTH} are allowed",
            0,
            "split it into several checks",
        )
    if not text.strip():
        raise ParseError("the expression is empty", 0, "write e.g. `final(plant.y) < 1.0`")
    parser = _Parser(tokenize(text))
    node = parser.expression()
    parser.finish()
    if depth(node) > MAX_DEPTH:
        raise ParseError(
            f"the expression is nested more than {MAX_DEPTH} levels deep",
            0,
            "split it into several checks",
        )
    return node


def children(node: Node) -> tuple[Node, ...]:
    """The nodes directly under ``node``."""
    match node:
        case Call(arguments=arguments):
            return tuple(a.value for a in arguments)
        case UnaryOp(operand=operand):
            return (operand,)
        case BinaryOp(left=left, right=right):
            return (left, right)
        case Group(items=items):
            return items
    return ()


def depth(node: Node) -> int:
    """Levels of ``node``'s tree (counted without recursion: a long chain is deep)."""
    deepest = 0
    stack = [(node, 1)]
    while stack:
        current, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in children(current))
    return deepest


class _Parser:
    """Recursive descent over the tokens, one method per grammar rule.

    ``depth`` counts the parser's own recursion (brackets, calls, prefix operators), so that
    hostile nesting ends in a ParseError rather than Python's RecursionError.
    """

    def __init__(self, tokens: list[Token]) -> None:
        self.tokens = tokens
        self.index = 0
        self.depth = 0

    @property
    def token(self) -> Token:
        return self.tokens[self.index]

    def advance(self) -> Token:
        token = self.tokens[self.index]
        if token.kind != "end":
            self.index += 1
        return token

    def at(self, *texts: str) -> bool:
        token = self.token
        if token.kind == "operator":
            return token.text in texts
        return token.kind == "name" and token.text in KEYWORDS and token.text in texts

    def expect(self, text: str, opening: Token) -> Token:
        if self.at(text):
            return self.advance()
        found = self.token
        if found.kind == "end":
            raise ParseError(f"`{opening.text}` is not closed", opening.start, f"add `{text}`")
        raise ParseError(
            f"expected `,` or `{text}`, found {_describe(found)}",
            found.start,
            f"separate the items with `,`, or close the `{opening.text}` with `{text}`",
        )

    def finish(self) -> None:
        token = self.token
        if token.kind == "end":
            return
        if token.text in (")", "]"):
            raise ParseError(f"`{token.text}` closes nothing", token.start)
        if token.text in COMPARISONS:
            raise ParseError(
                "comparisons do not chain",
                token.start,
                "compare one thing at a time: write two checks, or join conditions with `and`",
            )
        if token.text == "=":
            raise ParseError(
                "`=` names an argument inside a call; to compare, write `==`", token.start
            )
        raise ParseError(f"unexpected {_describe(token)} after a complete expression", token.start)

    def nested(self, start: int) -> None:
        """One more level of the parser's own recursion (brackets, calls, prefix operators)."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ParseError(
                f"the expression is nested more than {MAX_DEPTH} levels deep",
                start,
                "split it into several checks",
            )

    # -- grammar -------------------------------------------------------------------------------

    def expression(self) -> Node:
        self.nested(self.token.start)
        try:
            return self.logical("or", self.logical_and)
        finally:
            self.depth -= 1

    def logical_and(self) -> Node:
        return self.logical("and", self.negation)

    def logical(self, keyword: str, operand: _Rule) -> Node:
        left = operand()
        while self.at(keyword):
            at = self.advance().start
            right = operand()
            left = BinaryOp(keyword, left, right, at, _start(left), _end(right))
        return left

    def negation(self) -> Node:
        if self.at("not"):
            start = self.advance().start
            self.nested(start)
            try:
                operand = self.negation()
            finally:
                self.depth -= 1
            return UnaryOp("not", operand, start, _end(operand))
        return self.comparison()

    def comparison(self) -> Node:
        left = self.sum()
        if self.at(*COMPARISONS):
            token = self.advance()
            right = self.sum()
            return BinaryOp(token.text, left, right, token.start, _start(left), _end(right))
        return left

    def sum(self) -> Node:
        return self.chain(("+", "-"), self.term)

    def term(self) -> Node:
        return self.chain(("*", "/"), self.unary)

    def chain(self, operators: tuple[str, ...], operand: _Rule) -> Node:
        left = operand()
        while self.at(*operators):
            token = self.advance()
            right = operand()
            left = BinaryOp(token.text, left, right, token.start, _start(left), _end(right))
        return left

    def unary(self) -> Node:
        if self.at("-", "+"):
            token = self.advance()
            self.one_sign(token)
            self.nested(token.start)
            try:
                operand = self.unary()
            finally:
                self.depth -= 1
            return UnaryOp(token.text, operand, token.start, _end(operand))
        return self.primary()

    def one_sign(self, sign: Token) -> None:
        """A number has one sign at most (``["-" | "+"] NUMBER``): ``+-1`` was read as -1, and
        a bound written so was accepted (a bug hunt). Signs before anything else (``--x``)
        are operators, as the grammar's ``unary`` has them."""
        after = self.index
        while self.tokens[after].kind == "operator" and self.tokens[after].text in ("-", "+"):
            after += 1
        number = self.tokens[after]
        if after == self.index or number.kind != "number":
            return
        signs = "".join(t.text for t in self.tokens[self.index - 1 : after])
        negative = signs.count("-") % 2 == 1
        raise ParseError(
            f"`{signs}{number.text}` is not a number: a number has one sign at most",
            sign.start,
            f"write `{'-' if negative else ''}{number.text}`",
        )

    def primary(self) -> Node:
        token = self.token
        if token.kind == "number":
            self.advance()
            value = float(token.text)
            if not math.isfinite(value):  # 1e999: a bound no measure could cross
                raise ParseError(f"`{token.text}` is beyond the range of a number", token.start)
            return NumberLit(value, token.start, token.start + len(token.text))
        if token.kind == "quoted":
            self.advance()
            return Name(token.text, token.start, token.start + len(token.text))
        if token.kind == "name" and token.text not in KEYWORDS:
            self.advance()
            if self.at("("):
                return self.call(token)
            return Name(token.text, token.start, token.start + len(token.text))
        if self.at("(", "["):
            return self.group()
        if token.kind == "end":
            raise ParseError("the expression ends where a value is expected", token.start)
        hint = None
        if token.text == "=":
            hint = "`=` names an argument inside a call; to compare, write `==`"
        elif token.text in COMPARISONS:
            hint = "write one comparison: `<`, `<=`, `>`, `>=`, `==` or `!=`"
        raise ParseError(f"expected a value, found {_describe(token)}", token.start, hint)

    def call(self, name: Token) -> Node:
        opening = self.advance()
        arguments: list[Argument] = []
        if not self.at(")"):
            while True:
                arguments.append(self.argument())
                if not self.at(","):
                    break
                self.advance()
        closing = self.expect(")", opening)
        return Call(name.text, tuple(arguments), name.start, closing.start + 1)

    def argument(self) -> Argument:
        token = self.token
        following = self.tokens[min(self.index + 1, len(self.tokens) - 1)]
        if token.kind == "name" and following.kind == "operator" and following.text == "=":
            self.advance()
            self.advance()
            return Argument(token.text, self.expression(), token.start)
        return Argument(None, self.expression(), token.start)

    def group(self) -> Node:
        opening = self.advance()
        closer = ")" if opening.text == "(" else "]"
        items = [self.expression()]
        while self.at(","):
            self.advance()
            items.append(self.expression())
        closing = self.expect(closer, opening)
        if opening.text == "(" and len(items) == 1:
            return items[0]  # plain parentheses
        return Group(opening.text, tuple(items), opening.start, closing.start + 1)


def _start(node: Node) -> int:
    return node.start


def _end(node: Node) -> int:
    return node.end


def _describe(token: Token) -> str:
    if token.kind == "end":
        return "the end of the expression"
    return f"`{token.text}`"
