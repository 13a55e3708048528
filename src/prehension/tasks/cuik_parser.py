"""Parser for CuikSuite ``.world`` files: syntax and constant evaluation only.

This module reads the whole world language of CuikSuite (as its documentation and
examples use it) and returns plain frozen records (:mod:`prehension.tasks.cuik_records`).
It does not interpret the kinematics: points, displacements and reference vectors are
kept as written (after evaluating their expressions), in the frame of the link they are
written for.  What a task can be made of, and what is refused and why, is
:mod:`prehension.tasks.cuik_import` (and ``docs/cuik.md``).

The tokens and expressions are :mod:`prehension.tasks.cuik_expressions` (its docstring
has the lexical rules: ``%``, ``#``, ``//`` and ``/* */`` comments, case-insensitive
keywords, ``a::b`` names); bodies, colours, dynamics and transforms are
:mod:`prehension.tasks.cuik_shapes`; the joints :mod:`prehension.tasks.cuik_joints`.

Grammar (``[x]`` optional, ``x*`` repeated, ``|`` alternatives)
----------------------------------------------------------------
::

    world      := section*
    section    := "[CONSTANTS]" (NAME ":=" expr | "print" NAME)*
                | "[LINKS]" link* | "[JOINTS]" joint* | "[OBSTACLES]" (NAME ":" shape)*
                | "[COLLISIONS]" (["do" "not"] "check" ":" what)*
                | "[INCLUDE]" (NAME ":" STRING)* | "[EQUATIONS]" "eqfile" ":" STRING
    what       := "all" | "selfcollisions" | "connected" | LINK ["," LINK]
    link       := NAME [(":" | "-") [colour] shape* [dynamics]]     ("-": an end effector)
    shape      := "body" STRING [colour] [granularity] [status]
                | "box" point point2 [colour] [status]
                | "prism" point point point expr [colour] [status]
                | "sphere" expr point [colour] [granularity] [status]
                | "cylinder" expr point point2 [colour] [granularity] [status]
                | "line" point point2 [colour] [status]
                | "segments" "(" x,y,z (";" x,y,z)* ")" [colour]
    colour     := cterm ("+" cterm)*
    cterm      := NUMBER "*" cterm | red | green | blue | black | grey | white | yellow
                | purple | cyan | "color" "(" expr "," expr "," expr ")"
    granularity:= "granularity" INTEGER
    status     := "hidden" | "decoration"
    dynamics   := ["mass" expr] ["inertia" "matrix" inertia] ["inertial" "frame" transforms]
    transforms := transform ("*" transform)*
    transform  := "Id" | ("Tx"|"Ty"|"Tz"|"Rx"|"Ry"|"Rz") "(" expr ")" | "Txyz" "(" e "," e "," e ")"
                | "TR" "(" 4 exprs ";" 4 exprs ";" 4 exprs ")" ["^-1"]
    joint      := ("revolute" | "crevolute") ":" LINK jpoint point2 LINK jpoint point2
                      ["range" range ["reference"] ref ref | "reference" ref ref] [avoid] jdyn
                | "universal" ":" LINK jpoint point2 LINK jpoint point2
                      ["range" range ref range ref | "reference" ref ref] [avoid] jdyn
                | "spherical" ":" LINK jpoint LINK jpoint ["range" "[" expr "]" ref ref] [avoid] jdyn
                | "in_patch" ":" LINK jpoint point2 LINK jpoint jpoint jpoint jpoint [avoid] jdyn
                | "prismatic" ":" LINK jpoint point2 LINK jpoint point2 "range" range [avoid] jdyn
                | "fix" ":" LINK LINK transforms
                | "sph_sph" NAME ":" LINK jpoint LINK jpoint "length" expr "radius" expr
                      [granularity] [colour] [status] [dynamics] jdyn
                | ("sph_prs_sph" | "spring" | "xyspring") NAME ":" LINK jpoint LINK jpoint
                      "range" range "radius" expr [granularity] [colour] [status] ["rest" expr]
                      ["stiffness" expr] jdyn
                | ("c_cable" | "c_spring" | "c_leg") NAME ":" LINK jpoint LINK jpoint
                      "radius" expr [granularity] [colour] [status] ["rest" expr] ["stiffness" expr]
    jpoint     := point | INTEGER | INTEGER ":" INTEGER   (vertex N of body 0 / of body B)
    jdyn       := (("velocity" | "acceleration" | "effort" | "torque" | "force" | "cost"
                   | "friction" | "damping") expr)*
    point      := "(" expr "," expr "," expr ")"
    point2     := "+" point          (a displacement from the previous point)
                | point              (a second point, stored minus the previous one)
    ref        := "+" point | point  (a reference vector: displacement from the joint
                                      point on link 1 (first ref) / link 2 (second ref))
    range      := "[" expr "," expr "]"
    avoid      := "avoid" "limits" [expr]

An included file (``[INCLUDE] arm: "arm.world"``, relative to the including file) is read
in place, every name it defines prefixed ``arm__`` (as CuikSuite does); an error in it
names that file.  ``print NAME`` is accepted and prints nothing.  Names of constants and
of links live apart (as in CuikSuite); a name must not be a keyword; a constant must be
defined before it is used.  The first link listed is the ground link; links and joints
keep the order of the file.  A file that is not UTF-8 is read as Latin-1 (comments in old
examples).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import WorldFileError
from ..frozen import FrozenMap
from .cuik_expressions import SECTIONS, Problem, Token, evaluate_expression, tokenize
from .cuik_joints import JointReader
from .cuik_records import (
    COLOR_RGB, IMPORTED_JOINTS, JOINT_KINDS, Color, Vec3, WorldBody, WorldCollision, WorldFile, WorldJoint, WorldLink,
)
from .cuik_shapes import KEYWORDS, SHAPES

__all__ = [
    "Vec3", "Color", "COLOR_RGB", "WorldBody", "WorldLink", "WorldJoint", "WorldCollision", "WorldFile",
    "JOINT_KINDS", "IMPORTED_JOINTS", "parse_world", "read_world", "evaluate_expression",
]

_SECTIONS_TEXT = "sections: " + ", ".join(f"[{name}]" for name in SECTIONS)
_MAX_INCLUDES = 16


class _Parser(JointReader):
    """Recursive-descent parser of the statements over the token list; evaluates as it reads."""

    def __init__(self, tokens: list[Token], folder: Path | None):
        super().__init__(tokens)
        self.folder = folder
        self.constant_lines: dict[str, int] = {}
        self.links: dict[str, WorldLink] = {}
        self.joints: list[WorldJoint] = []
        self.obstacles: dict[str, WorldLink] = {}
        self.collisions: list[WorldCollision] = []
        self.equations: list[tuple[str, int]] = []
        self.section: str | None = None
        self.includes = 0

    # -- statements
    def parse(self) -> None:
        statement = {"CONSTANTS": self.constant, "LINKS": self.link, "JOINTS": self.joint_statement,
                     "OBSTACLES": self.obstacle, "COLLISIONS": self.collision, "INCLUDE": self.include,
                     "EQUATIONS": self.equation}
        while self.peek().kind != "eof":
            if self.peek().is_op("["):
                self.section_header()
            elif self.section is None:
                self.fail(f"expected a section header such as [CONSTANTS] before {self.peek().describe()}")
            else:
                statement[self.section]()

    def section_header(self) -> None:
        opened = self.advance()
        name = self.peek()
        if name.kind != "id" or not self.peek(1).is_op("]"):
            self.fail("malformed section header: expected [NAME]; " + _SECTIONS_TEXT, opened)
        self.pos += 2
        if name.text.upper() not in SECTIONS:
            self.fail(f"unknown section [{name.text}]; {_SECTIONS_TEXT}", opened)
        self.section = name.text.upper()

    def constant(self) -> None:
        if self.peek().is_word("print") and self.peek(1).kind == "id":
            self.advance()
            self.name_value()  # must be defined; CuikSuite prints it, prehension does not
            return
        name = self.name_token("constant")
        self.expect_op(":=", f"after constant name '{name.text}'")
        value = self.expr()
        if name.text in self.constant_lines:
            self.fail(f"constant '{name.text}' is defined twice: at line "
                      f"{self.constant_lines[name.text]} and again at line {name.line}", name)
        self.constants[name.text] = value
        self.constant_lines[name.text] = name.line

    def new_body_name(self, kind: str) -> Token:
        name = self.name_token(kind)
        for what, known in (("link", self.links), ("obstacle", self.obstacles)):
            if name.text in known:
                self.fail(f"{kind} '{name.text}' is defined twice: at line {known[name.text].line} "
                          f"(as a {what}) and again at line {name.line}", name)
        return name

    def link(self) -> None:
        name = self.new_body_name("link")
        fields: dict = {"name": name.text, "line": name.line}
        if self.peek().is_op(":") or self.peek().is_op("-"):
            fields["end_effector"] = self.advance().is_op("-")
            color = fields["color"] = self.optional_color()
            fields["bodies"] = tuple(self.shape(color) for _ in iter(lambda: self.peek().is_word(*SHAPES), False))
            fields["mass"] = self.link_dynamics()
        self.links[name.text] = WorldLink(**fields)

    def obstacle(self) -> None:
        name = self.new_body_name("obstacle")
        self.expect_op(":", f"after obstacle name '{name.text}'")
        if not self.peek().is_word(*SHAPES):
            self.fail(f"expected the obstacle's shape ({', '.join(SHAPES)}), found {self.peek().describe()}")
        self.obstacles[name.text] = WorldLink(name.text, name.line, (self.shape(None),))

    def collision(self) -> None:
        first = self.peek()
        check = not (first.is_word("do") and self.peek(1).is_word("not"))
        if not check:
            self.pos += 2
        self.expect_word("check", "(a collision statement is '[do not] check: all | selfcollisions | "
                                  "connected | LINK [, LINK]')")
        self.expect_op(":", "after 'check'")
        if self.peek().is_word("all", "selfcollisions", "connected"):
            what: tuple[str, ...] = (self.advance().text.lower(),)
        else:
            what = (self.body_ref(),)
            if self.peek().is_op(","):
                self.advance()
                what += (self.body_ref(),)
        self.collisions.append(WorldCollision(check, what, first.line))

    def body_ref(self) -> str:
        token = self.peek()
        bars = {j.name for j in self.joints if j.name}
        if token.kind != "id" or not any(token.text in known for known in (self.links, self.obstacles, bars)):
            self.fail(f"expected a link, obstacle or bar name, found {token.describe()}")
        return self.advance().text

    def equation(self) -> None:
        self.expect_word("eqfile", "([EQUATIONS] holds 'eqfile: \"file.cuik\"')")
        self.expect_op(":", "after 'eqfile'")
        token = self.peek()
        if token.kind != "str":
            self.fail(f"expected a quoted file name after 'eqfile:', found {token.describe()}")
        self.equations.append((self.advance().text[1:-1], token.line))

    def include(self) -> None:
        """``NAME: "file.world"``: the file's tokens in place, its names prefixed ``NAME__``."""
        name = self.name_token("include")
        self.expect_op(":", f"after include name '{name.text}'")
        token = self.peek()
        if token.kind != "str":
            self.fail(f"expected a quoted file name after '{name.text}:', found {token.describe()}")
        self.advance()
        self.includes += 1
        if self.includes > _MAX_INCLUDES:
            self.fail("includes nested too deeply (a file that includes itself?)", token)
        included = self.included_tokens(token, name.text)
        resume = [Token("op", "[", token.line, token.source), Token("id", "INCLUDE", token.line, token.source),
                  Token("op", "]", token.line, token.source)]
        self.tokens[self.pos:self.pos] = included[:-1] + resume

    def included_tokens(self, token: Token, prefix: str) -> list[Token]:
        relative = token.text[1:-1]
        path = (self.folder / relative) if self.folder is not None else Path(relative)
        if not path.is_file():
            self.fail(f"included file {relative!r} not found (looked for {path})", token)
        text = _decoded(path.read_bytes())
        tokens = tokenize(text, source=str(path))
        header = {i for i in range(1, len(tokens) - 1) if tokens[i - 1].is_op("[") and tokens[i + 1].is_op("]")}
        return [t if t.kind != "id" or t.text.lower() in KEYWORDS or i in header
                else Token("id", f"{prefix}__{t.text}", t.line, t.source) for i, t in enumerate(tokens)]

    def joint_statement(self) -> None:
        self.joints.append(self.joint())


# --------------------------------------------------------------------------- API


def parse_world(text: str, path: str | None = None) -> WorldFile:
    """Parse the text of a ``.world`` file; ``path`` labels error messages and is where
    included files and the body files of vertex references are looked for.

    Raises :class:`WorldFileError` (with ``path`` -- or the included file's -- and
    ``line``) on any syntax error, undefined or duplicated name, or arithmetic error.
    """
    if not text.strip():
        raise WorldFileError("the world file is empty", path=path)
    try:
        parser = _Parser(tokenize(text), Path(path).resolve().parent if path else None)
        parser.parse()
    except Problem as problem:
        raise WorldFileError(problem.message, path=problem.source or path, line=problem.line) from None
    return WorldFile(
        path=path,
        constants=FrozenMap(dict(parser.constants)),
        constant_lines=FrozenMap(dict(parser.constant_lines)),
        links=tuple(parser.links.values()),
        joints=tuple(parser.joints),
        obstacles=tuple(parser.obstacles.values()),
        collisions=tuple(parser.collisions),
        equations=tuple(parser.equations),
    )


def _decoded(data: bytes) -> str:
    """UTF-8 text, else Latin-1 (every byte is a character: old examples' comments)."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def read_world(path: str | Path) -> WorldFile:
    """Read and parse the ``.world`` file at ``path`` (UTF-8, else Latin-1 text)."""
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
    return parse_world(_decoded(data), path=name)
