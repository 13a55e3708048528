"""The CuikSuite world language's tokens and arithmetic: the lexer and the expression reader.

:mod:`prehension.tasks.cuik_parser` reads the statements of a ``.world`` file on top of
this (its docstring has the whole grammar); here are the tokens, the expressions
(``expr``, ``term``, ``unary``, ``power``, ``primary``, functions, constants) and the
points and ranges built of them, evaluated as they are read, never with Python's ``eval``.

Lexical rules
-------------
* ``%``, ``#`` and ``//`` start a comment that runs to the end of the line; ``/* ... */``
  (and ``/** ... */``) is a block comment.  Whitespace and newlines separate tokens and are
  otherwise insignificant: a statement may span several lines.
* Keywords (section names, joint kinds, ``range``, ``avoid``, ``limits``, ``body``,
  colours, ``pi``, function names...) are case-insensitive; identifiers (constant and
  link names) are case-sensitive.
* Numbers: ``12``, ``1.5``, ``.5``, ``5.``, ``1e-3``, ``2.5E+2``.  Strings: ``"..."``
  on one line.  A scoped name ``a::b`` is the identifier ``a__b`` (CuikSuite turns each
  ``:`` into ``_``).
* Comparisons ``==``, ``!=``, ``<=``, ``>=``, ``<``, ``>`` (1 when true, else 0) bind
  loosest, left to right; ``(c ? a : b)`` is ``a`` when ``c`` is not 0, else ``b``.
  ``PARAMETER(name)`` (a value of CuikSuite's solver parameter file) is refused: prehension
  has no such file, so the value is unknown.

CuikSuite's grammar makes unary minus bind tighter than ``^`` and ``^``
left-associative, unlike the usual mathematical convention.  So that an imported file
never means something other than what CuikSuite would read, the two forms on which the
conventions differ (a sign right before a power, ``-a^b``, and chained powers ``a^b^c``)
are refused with a request for parentheses; everything else reads the same both ways.  A name must be a constant defined
earlier; expressions are evaluated as they are read, never with Python's ``eval``.
"""

from __future__ import annotations

import math
import operator
import re
from dataclasses import dataclass
from functools import partial
from typing import Callable, Mapping, NoReturn

from ..errors import WorldFileError

__all__ = ["Vec3", "Problem", "Token", "tokenize", "FUNCTIONS", "SECTIONS", "ExpressionReader", "evaluate_expression"]

Vec3 = tuple[float, float, float]

_BINARY: dict[str, Callable[[float, float], float]] = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv,
    "==": operator.eq, "!=": operator.ne, "<=": operator.le, ">=": operator.ge,
    "<": operator.lt, ">": operator.gt,
}
_COMPARISONS = ("==", "!=", "<=", ">=", "<", ">")
SECTIONS = ("CONSTANTS", "LINKS", "JOINTS", "OBSTACLES", "COLLISIONS", "INCLUDE", "EQUATIONS")


def _cot(x: float) -> float:
    return math.tan(math.pi / 2 - x)


FUNCTIONS: dict[str, tuple[int, Callable[..., float]]] = {
    "sin": (1, math.sin), "cos": (1, math.cos), "tan": (1, math.tan), "cot": (1, _cot),
    "asin": (1, math.asin), "acos": (1, math.acos), "atan": (1, math.atan),
    "atan2": (2, math.atan2), "sqrt": (1, math.sqrt), "exp": (1, math.exp),
    "log": (1, math.log), "abs": (1, abs),
}


class Problem(Exception):
    """Internal: a parse error before the file path is attached."""

    def __init__(self, message: str, line: int, source: str | None = None):
        super().__init__(message)
        self.message = message
        self.line = line
        self.source = source  # the included file the line is in (None: the world file)


@dataclass(frozen=True)
class Token:
    kind: str  # "num", "id", "str", "op", "eof"
    text: str
    line: int
    source: str | None = None  # the included file the token comes from (None: the world file)

    def is_op(self, text: str) -> bool:
        return self.kind == "op" and self.text == text

    def is_word(self, *words: str) -> bool:
        return self.kind == "id" and self.text.lower() in words

    def describe(self) -> str:
        return "end of file" if self.kind == "eof" else repr(self.text)


_TOKEN_RE = re.compile(
    r"""(?P<ws>[ \t\r\f\v]+)
      | (?P<nl>\n)
      | (?P<comment>(?:%|\#|//)[^\n]*)
      | (?P<block>/\*)
      | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
      | (?P<id>[A-Za-z_][A-Za-z0-9_]*(?:::[A-Za-z][A-Za-z0-9_]*)*)
      | (?P<str>"[^"\n]*")
      | (?P<op>:=|==|!=|<=|>=|[<>?;:()\[\],+\-*/^])
    """,
    re.VERBOSE,
)


def tokenize(text: str, source: str | None = None) -> list[Token]:
    """The tokens of ``text``; ``source`` labels them (an included file), else ``None``."""
    tokens: list[Token] = []
    pos, line = 0, 1
    while pos < len(text):
        match = _TOKEN_RE.match(text, pos)
        if match is None:
            raise Problem(_bad_character(text, pos), line, source)
        kind, lexeme = match.lastgroup, match.group()
        if kind == "block":
            end = text.find("*/", pos + 2)
            if end < 0:
                raise Problem("unterminated block comment '/*' (no closing '*/')", line, source)
            line += text.count("\n", pos, end)
            pos = end + 2
            continue
        if kind == "nl":
            line += 1
        elif kind in ("num", "id", "str", "op"):
            tokens.append(Token(kind, lexeme.replace(":", "_") if kind == "id" else lexeme, line, source))
        pos = match.end()
    tokens.append(Token("eof", "", line, source))
    return tokens


def _bad_character(text: str, pos: int) -> str:
    if text[pos] == '"':
        return "unterminated string (a string must close with '\"' on the same line)"
    return f"unexpected character {text[pos]!r}"


class ExpressionReader:
    """Recursive-descent reader of expressions over a token list; evaluates as it reads
    (``constants``: the values of the names defined so far)."""

    def __init__(self, tokens: list[Token], constants: Mapping[str, float] | None = None):
        self.tokens = tokens
        self.pos = 0
        self.constants: dict[str, float] = dict(constants or {})

    # -- token helpers
    def peek(self, ahead: int = 0) -> Token:
        return self.tokens[min(self.pos + ahead, len(self.tokens) - 1)]

    def advance(self) -> Token:
        token = self.peek()
        self.pos = min(self.pos + 1, len(self.tokens) - 1)
        return token

    def fail(self, message: str, token: Token | None = None) -> NoReturn:
        token = token or self.peek()
        raise Problem(message, token.line, token.source)

    def expect_op(self, text: str, what: str) -> Token:
        token = self.peek()
        if not token.is_op(text):
            self.fail(f"expected '{text}' {what}, found {token.describe()}")
        return self.advance()

    def expect_word(self, word: str, what: str) -> None:
        if not self.peek().is_word(word):
            self.fail(f"expected '{word}' {what}, found {self.peek().describe()}")
        self.advance()

    def accept_word(self, *words: str) -> bool:
        if self.peek().is_word(*words):
            self.advance()
            return True
        return False

    # -- expressions
    def expr(self) -> float:
        """Comparisons (1 or 0) over sums, the loosest binding, as CuikSuite reads them."""
        return self.chain(_COMPARISONS, self.additive)

    def additive(self) -> float:
        return self.chain(("+", "-"), self.term)

    def term(self) -> float:
        return self.chain(("*", "/"), self.unary)

    def chain(self, operators: tuple[str, ...], operand: Callable[[], float]) -> float:
        """A left-associative chain ``operand (op operand)*`` over ``operators``."""
        value = operand()
        while self.peek().kind == "op" and self.peek().text in operators:
            op = self.advance()
            self.operand_follows(op)
            value = self.checked(op, partial(_BINARY[op.text], value, operand()))
        return value

    def operand_follows(self, op: Token) -> None:
        """Blame a dangling operator on its own line, not on what the next line starts."""
        token, after = self.peek(), self.peek(1)
        starts_next = (
            token.kind == "eof"
            or (token.kind == "id" and after.is_op(":="))
            or (token.is_op("[") and after.kind == "id" and after.text.upper() in SECTIONS)
        )  # fmt: skip
        if starts_next and token.line > op.line or token.kind == "eof":
            raise Problem(f"the expression ends with a dangling '{op.text}': an operand must follow it", op.line, op.source)

    def unary(self) -> float:
        token = self.peek()
        if token.is_op("-") or token.is_op("+"):
            self.advance()
            if self.peek().kind != "op" or self.peek().is_op("("):
                value, powered = self.power_or_primary()
                if powered:
                    raise Problem(
                        f"'{token.text}a^b' is ambiguous (CuikSuite reads ({token.text}a)^b, mathematics "
                        f"{token.text}(a^b)); add parentheses",
                        token.line,
                    )
            else:
                value = self.unary()
            return -value if token.text == "-" else value
        return self.power()

    def power(self) -> float:
        return self.power_or_primary()[0]

    def power_or_primary(self) -> tuple[float, bool]:
        """``primary ["^" unary]`` and whether a power was read.

        Chained powers and a sign before a power are refused: CuikSuite's grammar and
        the usual mathematical convention read them differently, and an imported task
        must never silently differ from what CuikSuite would solve.
        """
        base = self.primary()
        if not self.peek().is_op("^"):
            return base, False
        op = self.advance()
        exponent = self.signed_primary()
        if self.peek().is_op("^"):
            raise Problem("'a^b^c' is ambiguous (CuikSuite reads (a^b)^c); add parentheses", self.peek().line, self.peek().source)
        return self.checked(op, partial(math.pow, base, exponent), f"{base:g}^{exponent:g}"), True

    def signed_primary(self) -> float:
        """An exponent: ``("+" | "-")* primary``."""
        token = self.peek()
        if token.is_op("-") or token.is_op("+"):
            self.advance()
            value = self.signed_primary()
            return -value if token.text == "-" else value
        return self.primary()

    def primary(self) -> float:
        token = self.peek()
        if token.kind == "num":
            self.advance()
            return self.checked(token, partial(float, token.text), f"the number {token.text}")
        if token.is_op("("):
            self.advance()
            value = self.expr()
            if self.peek().is_op("?"):  # (c ? a : b)
                self.advance()
                chosen = self.expr()
                self.expect_op(":", f"in the '(c ? a : b)' opened at line {token.line}")
                other = self.expr()
                value = chosen if value != 0.0 else other
            self.expect_op(")", f"to close the '(' opened at line {token.line}")
            return value
        if token.kind == "id":
            return self.name_value()
        self.fail(f"expected a number, a constant name or '(' in an expression, "
                  f"found {token.describe()}")

    def name_value(self) -> float:
        token = self.advance()
        lower = token.text.lower()
        if lower == "pi":
            return math.pi
        if lower in FUNCTIONS:
            return self.call(token)
        if lower == "parameter" and self.peek().is_op("("):
            self.fail("PARAMETER(...) reads CuikSuite's solver parameter file (.param), which "
                      "prehension does not have; write the value (or a constant) instead", token)
        if token.text in self.constants:
            return self.constants[token.text]
        self.fail(f"undefined constant '{token.text}' (a constant must be defined with "
                  f"'{token.text} := ...' earlier in [CONSTANTS] before it is used)", token)

    def call(self, token: Token) -> float:
        name = token.text.lower()
        arity, function = FUNCTIONS[name]
        self.expect_op("(", f"after function '{name}'")
        args = [self.expr()]
        while self.peek().is_op(","):
            self.advance()
            args.append(self.expr())
        self.expect_op(")", f"to close the call of '{name}' opened at line {token.line}")
        if len(args) != arity:
            self.fail(f"function '{name}' takes {arity} argument(s), got {len(args)}", token)
        shown = ", ".join(f"{arg:g}" for arg in args)
        return self.checked(token, partial(function, *args), f"{name}({shown})")

    def checked(self, token: Token, compute: Callable[[], float], what: str = "") -> float:
        what = what or f"'{token.text}'"
        try:
            value = float(compute())
        except ZeroDivisionError:
            self.fail("division by zero", token)
        except (ValueError, OverflowError) as exc:
            self.fail(f"cannot evaluate {what}: {exc}", token)
        if not math.isfinite(value):
            self.fail(f"cannot evaluate {what}: the result is not finite", token)
        return value

    # -- points, ranges
    def point(self, what: str) -> Vec3:
        opened = self.expect_op("(", f"to start {what} (x, y, z)")
        values = [self.expr()]
        while self.peek().is_op(","):
            self.advance()
            values.append(self.expr())
        if not self.peek().is_op(")"):
            self.fail(f"expected ',' or ')' in {what} opened at line {opened.line}, "
                      f"found {self.peek().describe()}")
        self.advance()
        if len(values) != 3:
            self.fail(f"{what} needs 3 coordinates (x, y, z), found {len(values)}", opened)
        return (values[0], values[1], values[2])

    def displacement(self, origin: Vec3, what: str) -> Vec3:
        """``+(d)`` -> d as written; ``(q)`` -> q - origin."""
        if self.peek().is_op("+"):
            self.advance()
            return self.point(what)
        if self.peek().is_op("("):
            q = self.point(what)
            return (q[0] - origin[0], q[1] - origin[1], q[2] - origin[2])
        self.fail(f"expected {what} as '+(dx, dy, dz)' or '(x, y, z)', "
                  f"found {self.peek().describe()}")

    def interval(self) -> tuple[float, float]:
        opened = self.expect_op("[", "to start a range [lo, hi]")
        lo = self.expr()
        self.expect_op(",", "between the bounds of a range [lo, hi]")
        hi = self.expr()
        self.expect_op("]", f"to close the range opened at line {opened.line}")
        if lo > hi:
            self.fail(f"empty range [{lo:g}, {hi:g}] (lower bound above upper bound)", opened)
        return (lo, hi)


def evaluate_expression(text: str, constants: Mapping[str, float] | None = None) -> float:
    """Evaluate one world-language expression over ``constants`` (default: none).

    Raises :class:`WorldFileError` (``line`` counted within ``text``) on a syntax
    error, an undefined name, or an arithmetic error.
    """
    try:
        parser = ExpressionReader(tokenize(text), constants)
        value = parser.expr()
        if parser.peek().kind != "eof":
            parser.fail(f"unexpected {parser.peek().describe()} after the expression")
    except Problem as problem:
        raise WorldFileError(problem.message, line=problem.line) from None
    return value
