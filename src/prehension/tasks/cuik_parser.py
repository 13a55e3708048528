"""Parser for CuikSuite ``.world`` files: syntax and constant evaluation only.

This module reads the subset of CuikSuite's world language used by the grasp
problems of Rosales et al. (IJRR 2011) and returns plain frozen records.  It does
not interpret the kinematics: points, displacements and reference vectors are kept
as written (after evaluating their expressions), in the frame of the link they are
written for.

Lexical rules
-------------
* ``%`` starts a comment that runs to the end of the line; ``/* ... */`` (and
  ``/** ... */``) is a block comment.  Whitespace and newlines separate tokens and are
  otherwise insignificant: a statement may span several lines.
* Keywords (section names, joint kinds, ``range``, ``avoid``, ``limits``, ``body``,
  colours, ``pi``, function names...) are case-insensitive; identifiers (constant and
  link names) are case-sensitive.
* Numbers: ``12``, ``1.5``, ``.5``, ``5.``, ``1e-3``, ``2.5E+2``.  Strings: ``"..."``
  on one line.

Grammar (``[x]`` optional, ``x*`` repeated, ``|`` alternatives)
----------------------------------------------------------------
::

    world      := section*
    section    := "[CONSTANTS]" constant* | "[LINKS]" link* | "[JOINTS]" joint*
    constant   := NAME ":=" expr
    link       := NAME [":" [colour] shape*]
    shape      := "body" STRING [colour] [granularity] [status]
                | "sphere" expr point [colour] [granularity] [status]
                | "cylinder" expr point point2 [colour] [granularity] [status]
                | "box" point point2 [colour] [status]
    colour     := red | green | blue | black | grey | white | yellow | purple | cyan
                | "color" "(" expr "," expr "," expr ")"
    granularity:= "granularity" INTEGER
    status     := "hidden" | "decoration"
    joint      := "revolute" ":" LINK point point2 LINK point point2
                      ["range" range ["reference"] ref ref | "reference" ref ref] [avoid]
                | "universal" ":" LINK point point2 LINK point point2
                      ["range" range ref range ref | "reference" ref ref] [avoid]
                | "spherical" ":" LINK point LINK point
                      ["range" "[" expr "]" ref ref] [avoid]
                | "in_patch" ":" LINK point point2 LINK point point point point [avoid]
    point      := "(" expr "," expr "," expr ")"
    point2     := "+" point          (a displacement from the previous point)
                | point              (a second point, stored minus the previous one)
    ref        := "+" point | point  (a reference vector: displacement from the joint
                                      point on link 1 (first ref) / link 2 (second ref))
    range      := "[" expr "," expr "]"
    avoid      := "avoid" "limits" [expr]
    expr       := term (("+" | "-") term)*
    term       := unary (("*" | "/") unary)*
    unary      := ("+" | "-") unary | power
    power      := primary ["^" ("+" | "-")* primary]   (a^b^c and -a^b are refused)
    primary    := NUMBER | "pi" | NAME | "(" expr ")" | FUNCTION "(" expr ["," expr] ")"
    FUNCTION   := sin | cos | tan | cot | asin | acos | atan | atan2 | sqrt | exp
                | log | abs                        (atan2 takes two arguments)

CuikSuite's grammar makes unary minus bind tighter than ``^`` and ``^``
left-associative, unlike the usual mathematical convention.  So that an imported file
never means something other than what CuikSuite would read, the two forms on which the
conventions differ (a sign right before a power, ``-a^b``, and chained powers ``a^b^c``)
are refused with a request for parentheses; everything else reads the same both ways.  A name must be a constant defined
earlier; expressions are evaluated as they are read, never with Python's ``eval``.

Everything else CuikSuite accepts (``[OBSTACLES]``, ``[COLLISIONS]``, ``[INCLUDE]``,
prismatic/fix/... joints, masses, joint dynamics, body-vertex references, colour
arithmetic) is rejected with a :class:`~prehension.errors.WorldFileError` that names
the line and says what is supported.  The first link listed is the ground link; links
and joints keep the order of the file.
"""

from __future__ import annotations

import math
import operator
import re
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from ..frozen import FrozenMap
from typing import Callable, Mapping, NoReturn, Union

from ..errors import WorldFileError

__all__ = [
    "Vec3",
    "Color",
    "WorldBody",
    "WorldLink",
    "WorldJoint",
    "WorldFile",
    "JOINT_KINDS",
    "parse_world",
    "read_world",
    "evaluate_expression",
]

Vec3 = tuple[float, float, float]
Color = Union[str, Vec3]

JOINT_KINDS = ("revolute", "universal", "spherical", "in_patch")
_SUPPORTED_JOINTS = "supported joints: " + ", ".join(JOINT_KINDS)
_SUPPORTED_SECTIONS = ("CONSTANTS", "LINKS", "JOINTS")
_SUPPORTED_SECTIONS_TEXT = "prehension reads [CONSTANTS], [LINKS], [JOINTS]"
_SUPPORTED_SHAPES = "supported bodies: body \"file.off\", sphere, cylinder, box"

_JOINT_SYNTAX = {
    "revolute": "revolute: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) "
    "[range [lo,hi] +(a) +(b)] [avoid limits]",
    "universal": "universal: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) "
    "[range [lo1,hi1] +(a1) [lo2,hi2] +(a2)] [avoid limits]",
    "spherical": "spherical: LINK (x,y,z) LINK (x,y,z) [range [beta] +(m) +(n)] [avoid limits]",
    "in_patch": "in_patch: LINK (x,y,z) (dx,dy,dz) LINK (P0) (P1) (P2) (P3) [avoid limits]",
}
_UNSUPPORTED_JOINTS = frozenset(
    {"fix", "prismatic", "crevolute", "cylindrical", "sph_sph", "sph_prs_sph",
     "spring", "xyspring", "c_cable", "c_spring", "c_leg", "planar"}
)
_COLORS = frozenset({"red", "green", "blue", "black", "grey", "white", "yellow", "purple", "cyan"})
_SHAPES = frozenset({"body", "sphere", "cylinder", "box"})
_UNSUPPORTED_SHAPES = frozenset({"prism", "line", "segments", "ellipsoid"})
_STATUS = frozenset({"hidden", "decoration"})


_BINARY: dict[str, Callable[[float, float], float]] = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv,
}


def _cot(x: float) -> float:
    return math.tan(math.pi / 2 - x)


_FUNCTIONS: dict[str, tuple[int, Callable[..., float]]] = {
    "sin": (1, math.sin), "cos": (1, math.cos), "tan": (1, math.tan), "cot": (1, _cot),
    "asin": (1, math.asin), "acos": (1, math.acos), "atan": (1, math.atan),
    "atan2": (2, math.atan2), "sqrt": (1, math.sqrt), "exp": (1, math.exp),
    "log": (1, math.log), "abs": (1, abs),
}
_RESERVED = (
    frozenset({"pi", "color", "granularity", "range", "reference", "avoid", "limits"})
    | _COLORS | _SHAPES | _UNSUPPORTED_SHAPES | _STATUS | frozenset(_FUNCTIONS)
    | frozenset(JOINT_KINDS) | _UNSUPPORTED_JOINTS
)


# --------------------------------------------------------------------------- records


@dataclass(frozen=True)
class WorldBody:
    """One display body of a link, as written (not interpreted).

    ``kind`` is ``"off"`` (``body "file.off"``; ``path`` is the file name as written,
    relative to the world file), ``"sphere"`` (``radius``, ``points = (centre,)``),
    ``"cylinder"`` (``radius``, ``points = (end1, end2)``) or ``"box"``
    (``points = (corner1, corner2)``); a ``+(...)`` second point is resolved to an
    absolute one.  ``color`` is the body's colour, or the link's when the body states
    none (a name such as ``"white"``, or an RGB triple); ``status`` is ``"hidden"``,
    ``"decoration"`` or ``None``.
    """

    kind: str
    line: int
    path: str | None = None
    radius: float | None = None
    points: tuple[Vec3, ...] = ()
    color: Color | None = None
    granularity: int | None = None
    status: str | None = None


@dataclass(frozen=True)
class WorldLink:
    """A link: its name, the line of the name, its default colour and its bodies."""

    name: str
    line: int
    bodies: tuple[WorldBody, ...] = ()
    color: Color | None = None


@dataclass(frozen=True)
class WorldJoint:
    """One joint statement of ``[JOINTS]``, with every expression evaluated.

    * ``kind``: ``"revolute"``, ``"universal"``, ``"spherical"`` or ``"in_patch"``;
      ``line``: the line of the joint keyword.
    * ``point1`` / ``point2``: the joint point written for ``link1`` / ``link2`` (each in
      its link's frame); ``point2`` is ``None`` for ``in_patch``.
    * ``axis1`` / ``axis2``: the displacement written after ``point1`` / ``point2``
      (``+(d)`` is stored as ``d``; a plain second point ``(q)`` as ``q - point``).
      Revolute and universal have both; ``in_patch`` has ``axis1`` (its direction);
      spherical has neither.
    * ``ranges``: ``((lo, hi),)`` for a revolute joint, ``((lo1, hi1), (lo2, hi2))`` for
      a universal joint, ``()`` without ``range`` (and for spherical/in_patch).
    * ``cone_angle``: the ``range [beta]`` of a spherical joint, else ``None``.
    * ``range_vectors``: the two reference vectors as written -- revolute ``(a, b)``,
      universal ``(a1, a2)``, spherical ``(m, n)`` -- the first relative to ``point1``,
      the second to ``point2``; ``()`` when none are given.
    * ``patch``: the four ``in_patch`` control points in the order written, else ``None``.
    * ``avoid_limits`` and its optional weight ``avoid_limits_weight``.
    """

    kind: str
    line: int
    link1: str
    link2: str
    point1: Vec3
    point2: Vec3 | None
    axis1: Vec3 | None
    axis2: Vec3 | None
    ranges: tuple[tuple[float, float], ...] = ()
    range_vectors: tuple[Vec3, ...] = ()
    cone_angle: float | None = None
    patch: tuple[Vec3, Vec3, Vec3, Vec3] | None = None
    avoid_limits: bool = False
    avoid_limits_weight: float | None = None


@dataclass(frozen=True)
class WorldFile:
    """A parsed world: evaluated constants (read-only mappings), links, joints."""

    path: str | None
    constants: Mapping[str, float]
    constant_lines: Mapping[str, int]
    links: tuple[WorldLink, ...]
    joints: tuple[WorldJoint, ...]

    @property
    def ground(self) -> str | None:
        """The name of the first link listed (the ground), or ``None`` without links."""
        return self.links[0].name if self.links else None

    def link(self, name: str) -> WorldLink:
        """The link called ``name`` (``KeyError`` if there is none)."""
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)


# --------------------------------------------------------------------------- lexer


class _Problem(Exception):
    """Internal: a parse error before the file path is attached."""

    def __init__(self, message: str, line: int):
        super().__init__(message)
        self.message = message
        self.line = line


@dataclass(frozen=True)
class _Token:
    kind: str  # "num", "id", "str", "op", "eof"
    text: str
    line: int

    def is_op(self, text: str) -> bool:
        return self.kind == "op" and self.text == text

    def is_word(self, *words: str) -> bool:
        return self.kind == "id" and self.text.lower() in words

    def describe(self) -> str:
        return "end of file" if self.kind == "eof" else repr(self.text)


_TOKEN_RE = re.compile(
    r"""(?P<ws>[ \t\r\f\v]+)
      | (?P<nl>\n)
      | (?P<comment>%[^\n]*)
      | (?P<block>/\*)
      | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
      | (?P<id>[A-Za-z_][A-Za-z0-9_]*)
      | (?P<str>"[^"\n]*")
      | (?P<op>:=|[:()\[\],+\-*/^])
    """,
    re.VERBOSE,
)


def _tokenize(text: str) -> list[_Token]:
    tokens: list[_Token] = []
    pos, line = 0, 1
    while pos < len(text):
        match = _TOKEN_RE.match(text, pos)
        if match is None:
            raise _Problem(_bad_character(text, pos), line)
        kind, lexeme = match.lastgroup, match.group()
        if kind == "block":
            end = text.find("*/", pos + 2)
            if end < 0:
                raise _Problem("unterminated block comment '/*' (no closing '*/')", line)
            line += text.count("\n", pos, end)
            pos = end + 2
            continue
        if kind == "nl":
            line += 1
        elif kind in ("num", "id", "str", "op"):
            tokens.append(_Token(kind, lexeme, line))
        pos = match.end()
    tokens.append(_Token("eof", "", line))
    return tokens


def _bad_character(text: str, pos: int) -> str:
    if text[pos] == '"':
        return "unterminated string (a string must close with '\"' on the same line)"
    return f"unexpected character {text[pos]!r}"


# --------------------------------------------------------------------------- parser


class _Parser:
    """Recursive-descent parser over the token list; evaluates as it reads."""

    def __init__(self, tokens: list[_Token], constants: Mapping[str, float] | None = None):
        self.tokens = tokens
        self.pos = 0
        self.constants: dict[str, float] = dict(constants or {})
        self.constant_lines: dict[str, int] = {}
        self.links: dict[str, WorldLink] = {}
        self.joints: list[WorldJoint] = []
        self.section: str | None = None

    # -- token helpers
    def peek(self, ahead: int = 0) -> _Token:
        return self.tokens[min(self.pos + ahead, len(self.tokens) - 1)]

    def advance(self) -> _Token:
        token = self.peek()
        self.pos = min(self.pos + 1, len(self.tokens) - 1)
        return token

    def fail(self, message: str, token: _Token | None = None) -> NoReturn:
        raise _Problem(message, (token or self.peek()).line)

    def expect_op(self, text: str, what: str) -> _Token:
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

    def operand_follows(self, op: _Token) -> None:
        """Blame a dangling operator on its own line, not on what the next line starts."""
        token, after = self.peek(), self.peek(1)
        starts_next = (
            token.kind == "eof"
            or (token.kind == "id" and after.is_op(":="))
            or (token.is_op("[") and after.kind == "id" and after.text.upper() in ("CONSTANTS", "LINKS", "JOINTS"))
        )  # fmt: skip
        if starts_next and token.line > op.line or token.kind == "eof":
            raise _Problem(f"the expression ends with a dangling '{op.text}': an operand must follow it", op.line)

    def unary(self) -> float:
        token = self.peek()
        if token.is_op("-") or token.is_op("+"):
            self.advance()
            if self.peek().kind != "op" or self.peek().is_op("("):
                value, powered = self.power_or_primary()
                if powered:
                    raise _Problem(
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
            raise _Problem("'a^b^c' is ambiguous (CuikSuite reads (a^b)^c); add parentheses", self.peek().line)
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
        if lower in _FUNCTIONS:
            return self.call(token)
        if token.text in self.constants:
            return self.constants[token.text]
        self.fail(f"undefined constant '{token.text}' (a constant must be defined with "
                  f"'{token.text} := ...' earlier in [CONSTANTS] before it is used)", token)

    def call(self, token: _Token) -> float:
        name = token.text.lower()
        arity, function = _FUNCTIONS[name]
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

    def checked(self, token: _Token, compute: Callable[[], float], what: str = "") -> float:
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

    # -- statements
    def parse(self) -> None:
        while self.peek().kind != "eof":
            if self.peek().is_op("["):
                self.section_header()
            elif self.section is None:
                self.fail(f"expected a section header such as [CONSTANTS] before "
                          f"{self.peek().describe()}")
            elif self.section == "CONSTANTS":
                self.constant()
            elif self.section == "LINKS":
                self.link()
            else:
                self.joint()

    def section_header(self) -> None:
        opened = self.advance()
        name = self.peek()
        if name.kind != "id" or not self.peek(1).is_op("]"):
            self.fail("malformed section header: expected [NAME]; " + _SUPPORTED_SECTIONS_TEXT,
                      opened)
        self.pos += 2
        if name.text.upper() not in _SUPPORTED_SECTIONS:
            self.fail(f"section [{name.text}] is not supported; {_SUPPORTED_SECTIONS_TEXT}",
                      opened)
        self.section = name.text.upper()

    def new_name(self, kind: str) -> _Token:
        token = self.peek()
        if token.kind != "id":
            self.fail(f"expected a {kind} name, found {token.describe()}")
        if token.text.lower() in _RESERVED:
            self.fail(f"'{token.text}' is a keyword and cannot be used as a {kind} name")
        return self.advance()

    def constant(self) -> None:
        name = self.new_name("constant")
        self.expect_op(":=", f"after constant name '{name.text}'")
        value = self.expr()
        if name.text in self.constant_lines:
            self.fail(f"constant '{name.text}' is defined twice: at line "
                      f"{self.constant_lines[name.text]} and again at line {name.line}", name)
        self.constants[name.text] = value
        self.constant_lines[name.text] = name.line

    def link(self) -> None:
        name = self.new_name("link")
        if name.text in self.links:
            self.fail(f"link '{name.text}' is defined twice: at line "
                      f"{self.links[name.text].line} and again at line {name.line}", name)
        if name.text in self.constant_lines:
            self.fail(f"link '{name.text}' has the name of the constant defined at line "
                      f"{self.constant_lines[name.text]}", name)
        color, bodies = None, []
        if self.peek().is_op(":"):
            self.advance()
            color = self.optional_color()
            while self.peek().is_word(*_SHAPES, *_UNSUPPORTED_SHAPES):
                bodies.append(self.shape(color))
        self.links[name.text] = WorldLink(name.text, name.line, tuple(bodies), color)

    def optional_color(self) -> Color | None:
        token = self.peek()
        if token.is_word(*_COLORS):
            self.advance()
            return token.text.lower()
        if token.is_word("color"):
            self.advance()
            return self.point("an RGB colour")
        return None

    def shape(self, link_color: Color | None) -> WorldBody:
        token = self.advance()
        kind = token.text.lower()
        if kind in _UNSUPPORTED_SHAPES:
            self.fail(f"body shape '{kind}' is not supported; {_SUPPORTED_SHAPES}", token)
        fields: dict = {"kind": kind, "line": token.line}
        if kind == "body":
            path = self.peek()
            if path.kind != "str":
                self.fail(f"expected a quoted file name after 'body', found {path.describe()}")
            self.advance()
            fields.update(kind="off", path=path.text[1:-1])
        elif kind == "sphere":
            fields.update(radius=self.expr(), points=(self.point("the sphere centre"),))
        else:
            if kind == "cylinder":
                fields["radius"] = self.expr()
            first = self.point(f"the first {kind} point")
            d = self.displacement(first, f"the second {kind} point")
            fields["points"] = (first, (first[0] + d[0], first[1] + d[1], first[2] + d[2]))
        color = self.optional_color()
        fields["color"] = color if color is not None else link_color
        if kind != "box" and self.accept_word("granularity"):
            fields["granularity"] = self.integer("after 'granularity'")
        if self.peek().is_word(*_STATUS):
            fields["status"] = self.advance().text.lower()
        return WorldBody(**fields)

    def integer(self, what: str) -> int:
        token = self.peek()
        if token.kind != "num" or not token.text.isdigit():
            self.fail(f"expected an integer {what}, found {token.describe()}")
        self.advance()
        return int(token.text)

    # -- joints
    def joint(self) -> None:
        keyword = self.peek()
        kind = keyword.text.lower() if keyword.kind == "id" else ""
        if kind in _UNSUPPORTED_JOINTS:
            self.fail(f"joint type '{keyword.text}' is not supported; {_SUPPORTED_JOINTS}")
        if kind not in JOINT_KINDS or not self.peek(1).is_op(":"):
            self.fail(f"expected a joint statement 'KIND: ...', found {keyword.describe()}; "
                      f"{_SUPPORTED_JOINTS}")
        self.pos += 2
        try:
            joint = getattr(self, f"joint_{kind}")(keyword.line)
        except _Problem as problem:
            where = "" if problem.line == keyword.line else f" starting at line {keyword.line}"
            raise _Problem(f"{problem.message} (in the {kind} joint{where}; expected "
                           f"'{_JOINT_SYNTAX[kind]}'; {_SUPPORTED_JOINTS})", problem.line) from None
        self.joints.append(joint)

    def link_ref(self) -> str:
        token = self.peek()
        if token.kind != "id":
            self.fail(f"expected a link name, found {token.describe()}")
        if token.text not in self.links:
            known = ", ".join(self.links) or "none"
            self.fail(f"unknown link '{token.text}' (links defined in [LINKS] so far: {known})")
        self.advance()
        return token.text

    def two_links(self, link1: str, link2: str, line: int) -> None:
        if link1 == link2:
            raise _Problem(f"a joint must connect two different links, got '{link1}' twice", line)

    def avoid(self) -> tuple[bool, float | None]:
        if not self.accept_word("avoid"):
            return False, None
        self.expect_word("limits", "after 'avoid'")
        return True, (self.expr() if self.starts_weight() else None)

    def starts_weight(self) -> bool:
        token = self.peek()
        if token.kind == "num" or token.is_op("(") or token.is_op("-") or token.is_op("+"):
            return True
        if token.kind != "id" or self.peek(1).is_op(":"):
            return False
        return token.text in self.constants or token.text.lower() in ("pi", *_FUNCTIONS)

    def pair(self) -> tuple[str, Vec3, Vec3]:
        link = self.link_ref()
        point = self.point(f"the joint point on '{link}'")
        axis = self.displacement(point, f"the axis displacement on '{link}'")
        return link, point, axis

    def refs(self, point1: Vec3, point2: Vec3) -> tuple[Vec3, Vec3]:
        first = self.displacement(point1, "the first reference vector")
        second = self.displacement(point2, "the second reference vector")
        return first, second

    def joint_revolute(self, line: int) -> WorldJoint:
        return self.axis_joint("revolute", line)

    def joint_universal(self, line: int) -> WorldJoint:
        return self.axis_joint("universal", line)

    def axis_joint(self, kind: str, line: int) -> WorldJoint:
        """A revolute (one axis) or universal (two axes) joint: two ``link point axis``
        triples, then optionally ``range [lo, hi] [reference] ref1 ref2`` (revolute) or
        ``range [lo1, hi1] ref1 [lo2, hi2] ref2`` (universal), or ``reference ref1 ref2``,
        then ``avoid limits [weight]``."""
        link1, p1, a1 = self.pair()
        link2, p2, a2 = self.pair()
        self.two_links(link1, link2, line)
        ranges: tuple[tuple[float, float], ...] = ()
        vectors: tuple[Vec3, ...] = ()
        if self.accept_word("range"):
            if kind == "revolute":
                ranges = (self.interval(),)
                self.accept_word("reference")
                vectors = self.refs(p1, p2)
            else:
                range1 = self.interval()
                ref1 = self.displacement(p1, "the first reference vector")
                range2 = self.interval()
                ref2 = self.displacement(p2, "the second reference vector")
                ranges, vectors = (range1, range2), (ref1, ref2)
        elif self.accept_word("reference"):
            vectors = self.refs(p1, p2)
        avoid, weight = self.avoid()
        return WorldJoint(kind, line, link1, link2, p1, p2, a1, a2, ranges, vectors,
                          avoid_limits=avoid, avoid_limits_weight=weight)

    def joint_spherical(self, line: int) -> WorldJoint:
        link1 = self.link_ref()
        p1 = self.point(f"the joint point on '{link1}'")
        link2 = self.link_ref()
        p2 = self.point(f"the joint point on '{link2}'")
        self.two_links(link1, link2, line)
        beta: float | None = None
        vectors: tuple[Vec3, ...] = ()
        if self.accept_word("range"):
            opened = self.expect_op("[", "to start the cone angle [beta]")
            beta = self.expr()
            self.expect_op("]", f"to close the cone angle opened at line {opened.line}")
            vectors = self.refs(p1, p2)
        avoid, weight = self.avoid()
        return WorldJoint("spherical", line, link1, link2, p1, p2, None, None, (), vectors,
                          cone_angle=beta, avoid_limits=avoid, avoid_limits_weight=weight)

    def joint_in_patch(self, line: int) -> WorldJoint:
        link1, p1, direction = self.pair()
        link2 = self.link_ref()
        self.two_links(link1, link2, line)
        c = [self.point(f"patch control point P{i}") for i in range(4)]
        avoid, weight = self.avoid()
        return WorldJoint("in_patch", line, link1, link2, p1, None, direction, None,
                          patch=(c[0], c[1], c[2], c[3]), avoid_limits=avoid,
                          avoid_limits_weight=weight)


# --------------------------------------------------------------------------- API


def parse_world(text: str, path: str | None = None) -> WorldFile:
    """Parse the text of a ``.world`` file; ``path`` only labels error messages.

    Raises :class:`WorldFileError` (with ``path`` and ``line``) on any syntax error,
    undefined or duplicated name, arithmetic error or unsupported construct.
    """
    if not text.strip():
        raise WorldFileError("the world file is empty", path=path)
    try:
        parser = _Parser(_tokenize(text))
        parser.parse()
    except _Problem as problem:
        raise WorldFileError(problem.message, path=path, line=problem.line) from None
    return WorldFile(
        path=path,
        constants=FrozenMap(dict(parser.constants)),
        constant_lines=FrozenMap(dict(parser.constant_lines)),
        links=tuple(parser.links.values()),
        joints=tuple(parser.joints),
    )


def read_world(path: str | Path) -> WorldFile:
    """Read and parse the ``.world`` file at ``path`` (UTF-8 text)."""
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise WorldFileError("no such world file", path=name) from None
    except IsADirectoryError:
        raise WorldFileError("is a directory, not a world file", path=name) from None
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise WorldFileError(f"cannot read the world file: {reason}", path=name) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise WorldFileError(f"the world file is not UTF-8 text (byte {exc.start})",
                             path=name) from None
    return parse_world(text, path=name)


def evaluate_expression(text: str, constants: Mapping[str, float] | None = None) -> float:
    """Evaluate one world-language expression over ``constants`` (default: none).

    Raises :class:`WorldFileError` (``line`` counted within ``text``) on a syntax
    error, an undefined name, or an arithmetic error.
    """
    try:
        parser = _Parser(_tokenize(text), constants)
        value = parser.expr()
        if parser.peek().kind != "eof":
            parser.fail(f"unexpected {parser.peek().describe()} after the expression")
    except _Problem as problem:
        raise WorldFileError(problem.message, line=problem.line) from None
    return value
