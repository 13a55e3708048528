"""Parser for CuikSuite ``.world`` files: syntax and constant evaluation only.

This module reads the subset of CuikSuite's world language used by the grasp
problems of Rosales et al. (IJRR 2011) and returns plain frozen records.  It does
not interpret the kinematics: points, displacements and reference vectors are kept
as written (after evaluating their expressions), in the frame of the link they are
written for.

The tokens, and the expressions with their evaluation, are
:mod:`prehension.tasks.cuik_expressions` (its docstring has the lexical rules).

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

CuikSuite's reading of ``-a^b`` and ``a^b^c`` differs from the usual convention; both
are refused with a request for parentheses (:mod:`prehension.tasks.cuik_expressions`).
A name must be a constant defined earlier.

Everything else CuikSuite accepts (``[OBSTACLES]``, ``[COLLISIONS]``, ``[INCLUDE]``,
prismatic/fix/... joints, masses, joint dynamics, body-vertex references, colour
arithmetic) is rejected with a :class:`~prehension.errors.WorldFileError` that names
the line and says what is supported.  The first link listed is the ground link; links
and joints keep the order of the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Union

from ..errors import WorldFileError
from ..frozen import FrozenMap
from .cuik_expressions import FUNCTIONS, ExpressionReader, Problem, Token, Vec3, evaluate_expression, tokenize

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


_RESERVED = (
    frozenset({"pi", "color", "granularity", "range", "reference", "avoid", "limits"})
    | _COLORS | _SHAPES | _UNSUPPORTED_SHAPES | _STATUS | frozenset(FUNCTIONS)
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


# --------------------------------------------------------------------------- parser


class _Parser(ExpressionReader):
    """Recursive-descent parser of the statements over the token list; evaluates as it reads."""

    def __init__(self, tokens: list[Token], constants: Mapping[str, float] | None = None):
        super().__init__(tokens, constants)
        self.constant_lines: dict[str, int] = {}
        self.links: dict[str, WorldLink] = {}
        self.joints: list[WorldJoint] = []
        self.section: str | None = None

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

    def new_name(self, kind: str) -> Token:
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
        except Problem as problem:
            where = "" if problem.line == keyword.line else f" starting at line {keyword.line}"
            raise Problem(f"{problem.message} (in the {kind} joint{where}; expected "
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
            raise Problem(f"a joint must connect two different links, got '{link1}' twice", line)

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
        return token.text in self.constants or token.text.lower() in ("pi", *FUNCTIONS)

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
        parser = _Parser(tokenize(text))
        parser.parse()
    except Problem as problem:
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
