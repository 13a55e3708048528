"""The CuikSuite world language's joint statements (``[JOINTS]``), read into
:class:`~prehension.tasks.cuik_records.WorldJoint` records.

:mod:`prehension.tasks.cuik_parser` has the whole grammar.  Here: every joint kind of the
language, the joint points (``(x,y,z)``, or a vertex of a link's body: ``N`` for body 0,
``B:N`` for body ``B``), the ranges and reference vectors, ``avoid limits [w]`` and the
joint dynamics (``velocity``, ``acceleration``, ``effort``/``torque``/``force``, ``cost``,
``friction``, ``damping``), read in any order.
"""

from __future__ import annotations

from pathlib import Path

from ..frozen import FrozenMap
from .cuik_expressions import FUNCTIONS, Problem, Vec3
from .cuik_records import JOINT_KINDS, WorldBody, WorldJoint, WorldLink
from .cuik_shapes import ShapeReader

__all__ = ["JointReader", "JOINT_SYNTAX"]

JOINT_SYNTAX = {
    "revolute": "revolute: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) "
    "[range [lo,hi] +(a) +(b)] [avoid limits]",
    "crevolute": "crevolute: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) range [lo,hi] +(a) +(b)",
    "universal": "universal: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) "
    "[range [lo1,hi1] +(a1) [lo2,hi2] +(a2)] [avoid limits]",
    "spherical": "spherical: LINK (x,y,z) LINK (x,y,z) [range [beta] +(m) +(n)] [avoid limits]",
    "in_patch": "in_patch: LINK (x,y,z) (dx,dy,dz) LINK (P0) (P1) (P2) (P3) [avoid limits]",
    "fix": "fix: LINK LINK Tx(a)*Rz(b)*...",
    "prismatic": "prismatic: LINK (x,y,z)+(dx,dy,dz) LINK (x,y,z)+(dx,dy,dz) range [lo,hi] [avoid limits]",
    "sph_sph": "sph_sph NAME: LINK (x,y,z) LINK (x,y,z) length L radius r [granularity n] [colour]",
    "sph_prs_sph": "sph_prs_sph NAME: LINK (x,y,z) LINK (x,y,z) range [lo,hi] radius r [granularity n] [colour]",
    "spring": "spring NAME: LINK (x,y,z) LINK (x,y,z) range [lo,hi] radius r [rest l] [stiffness k]",
    "c_cable": "c_cable NAME: LINK (x,y,z) LINK (x,y,z) radius r [rest l] [stiffness k]",
}
JOINT_SYNTAX["xyspring"] = JOINT_SYNTAX["spring"].replace("spring", "xyspring", 1)
JOINT_SYNTAX["c_spring"] = JOINT_SYNTAX["c_cable"].replace("c_cable", "c_spring")
JOINT_SYNTAX["c_leg"] = JOINT_SYNTAX["c_cable"].replace("c_cable", "c_leg")
_ALL_JOINTS = "joints: " + ", ".join(JOINT_KINDS)
_NAMED = ("sph_sph", "sph_prs_sph", "spring", "xyspring", "c_cable", "c_spring", "c_leg")
_DYNAMICS = {"velocity": "velocity", "acceleration": "acceleration", "effort": "effort",
             "torque": "effort", "force": "effort", "cost": "cost", "friction": "friction",
             "damping": "damping"}


class JointReader(ShapeReader):
    """Reads one joint statement; ``self.links`` (the links so far) and ``self.folder`` (the
    world file's folder, for the vertices of body files) are the parser's."""

    links: dict[str, WorldLink]
    folder: Path | None

    def joint(self) -> WorldJoint:
        keyword = self.peek()
        kind = keyword.text.lower() if keyword.kind == "id" else ""
        named = kind in _NAMED and self.peek(1).kind == "id" and self.peek(2).is_op(":")
        if kind not in JOINT_KINDS or not (named or self.peek(1).is_op(":")):
            self.fail(f"expected a joint statement 'KIND: ...', found {keyword.describe()}; {_ALL_JOINTS}")
        name = self.peek(1).text if named else None
        self.pos += 3 if named else 2
        try:
            reader = getattr(self, f"joint_{kind}", None) or (self.joint_bar if kind in _NAMED else None)
            joint = reader(kind, keyword.line)
        except Problem as problem:
            where = "" if problem.line == keyword.line else f" starting at line {keyword.line}"
            raise Problem(f"{problem.message} (in the {kind} joint{where}; expected "
                          f"'{JOINT_SYNTAX[kind]}')", problem.line, problem.source) from None
        return WorldJoint(**{**joint, "kind": kind, "line": keyword.line, "name": name})

    # -- pieces
    def link_ref(self) -> str:
        token = self.peek()
        if token.kind != "id":
            self.fail(f"expected a link name, found {token.describe()}")
        if token.text not in self.links:
            known = ", ".join(self.links) or "none"
            self.fail(f"unknown link '{token.text}' (links defined in [LINKS] so far: {known})")
        self.advance()
        return token.text

    def joint_point(self, link: str, what: str) -> Vec3:
        """``(x,y,z)``, or a vertex of one of ``link``'s bodies: ``N`` (body 0) or ``B:N``."""
        token = self.peek()
        if token.kind != "num":
            return self.point(what)
        self.advance()
        body, index = 0, token.text
        if self.peek().is_op(":") and self.peek(1).kind == "num":
            body, index = int(token.text) if token.text.isdigit() else -1, self.peek(1).text
            self.pos += 2
        if body < 0 or not index.isdigit():
            self.fail(f"a body-vertex reference is 'N' or 'B:N' with integers, found {token.text!r}", token)
        return self.vertex(link, body, int(index), token.line)

    def vertex(self, link: str, body: int, index: int, line: int) -> Vec3:
        bodies = self.links[link].bodies
        if body >= len(bodies):
            raise Problem(f"link '{link}' has {len(bodies)} bodies; there is no body {body} to take vertex "
                          f"{index} of", line)
        try:
            points = _defining_points(bodies[body], self.folder)
        except Problem as problem:
            raise Problem(problem.message, line) from None
        if points is None:
            raise Problem(f"vertex {index} of body {body} of '{link}': a {bodies[body].kind} body has no "
                          "vertices to refer to", line)
        if index >= len(points):
            raise Problem(f"body {body} of '{link}' has {len(points)} defining points; there is no point "
                          f"{index}", line)
        return points[index]

    def pair(self) -> tuple[str, Vec3, Vec3]:
        link = self.link_ref()
        point = self.joint_point(link, f"the joint point on '{link}'")
        axis = self.displacement(point, f"the axis displacement on '{link}'")
        return link, point, axis

    def two_points(self) -> tuple[str, Vec3, str, Vec3]:
        link1 = self.link_ref()
        p1 = self.joint_point(link1, f"the joint point on '{link1}'")
        link2 = self.link_ref()
        p2 = self.joint_point(link2, f"the joint point on '{link2}'")
        return link1, p1, link2, p2

    def two_links(self, link1: str, link2: str, line: int) -> None:
        if link1 == link2:
            raise Problem(f"a joint must connect two different links, got '{link1}' twice", line)

    def refs(self, point1: Vec3, point2: Vec3) -> tuple[Vec3, Vec3]:
        first = self.displacement(point1, "the first reference vector")
        second = self.displacement(point2, "the second reference vector")
        return first, second

    def avoid(self) -> dict:
        if not self.accept_word("avoid"):
            return {}
        self.expect_word("limits", "after 'avoid'")
        return {"avoid_limits": True, "avoid_limits_weight": self.expr() if self.starts_weight() else None}

    def starts_weight(self) -> bool:
        token = self.peek()
        if token.kind == "num" or token.is_op("(") or token.is_op("-") or token.is_op("+"):
            return True
        if token.kind != "id" or self.peek(1).is_op(":"):
            return False
        return token.text in self.constants or token.text.lower() in ("pi", *FUNCTIONS)

    def numbers(self, *words: str) -> dict[str, float]:
        """Optional ``WORD expr`` pairs (e.g. the joint dynamics), in any order, each once."""
        found: dict[str, float] = {}
        while self.peek().is_word(*words):
            token = self.advance()
            key = _DYNAMICS.get(token.text.lower(), token.text.lower())
            if key in found:
                self.fail(f"'{token.text}' is given twice", token)
            found[key] = self.expr()
        return found

    def dynamics(self) -> dict:
        return {"properties": FrozenMap(self.numbers(*_DYNAMICS))}

    # -- the statements (each returns the WorldJoint fields it read)
    def joint_fix(self, kind: str, line: int) -> dict:
        link1, link2 = self.link_ref(), self.link_ref()
        self.two_links(link1, link2, line)
        return dict(link1=link1, link2=link2, point1=(0.0, 0.0, 0.0), point2=None, axis1=None, axis2=None,
                    transform=self.transforms())

    def joint_revolute(self, kind: str, line: int) -> dict:
        return self.axis_joint(line)

    def joint_crevolute(self, kind: str, line: int) -> dict:
        return self.axis_joint(line)

    def joint_universal(self, kind: str, line: int) -> dict:
        return self.axis_joint(line, universal=True)

    def axis_joint(self, line: int, universal: bool = False) -> dict:
        """Two ``link point axis`` triples, then optionally ``range [lo, hi] [reference] ref1
        ref2`` (revolute) or ``range [lo1, hi1] ref1 [lo2, hi2] ref2`` (universal), or
        ``reference ref1 ref2``, then ``avoid limits [weight]`` and the dynamics."""
        link1, p1, a1 = self.pair()
        link2, p2, a2 = self.pair()
        self.two_links(link1, link2, line)
        fields = dict(link1=link1, link2=link2, point1=p1, point2=p2, axis1=a1, axis2=a2)
        if self.accept_word("range"):
            if not universal:
                fields["ranges"] = (self.interval(),)
                self.accept_word("reference")
                fields["range_vectors"] = self.refs(p1, p2)
            else:
                range1 = self.interval()
                ref1 = self.displacement(p1, "the first reference vector")
                range2 = self.interval()
                ref2 = self.displacement(p2, "the second reference vector")
                fields.update(ranges=(range1, range2), range_vectors=(ref1, ref2))
        elif self.accept_word("reference"):
            fields["range_vectors"] = self.refs(p1, p2)
        return {**fields, **self.avoid(), **self.dynamics()}

    def joint_prismatic(self, kind: str, line: int) -> dict:
        link1, p1, a1 = self.pair()
        link2, p2, a2 = self.pair()
        self.two_links(link1, link2, line)
        self.expect_word("range", "(a prismatic joint needs its range [lo, hi])")
        fields = dict(link1=link1, link2=link2, point1=p1, point2=p2, axis1=a1, axis2=a2, ranges=(self.interval(),))
        return {**fields, **self.avoid(), **self.dynamics()}

    def joint_spherical(self, kind: str, line: int) -> dict:
        link1, p1, link2, p2 = self.two_points()
        self.two_links(link1, link2, line)
        fields = dict(link1=link1, link2=link2, point1=p1, point2=p2, axis1=None, axis2=None)
        if self.accept_word("range"):
            opened = self.expect_op("[", "to start the cone angle [beta]")
            fields["cone_angle"] = self.expr()
            self.expect_op("]", f"to close the cone angle opened at line {opened.line}")
            fields["range_vectors"] = self.refs(p1, p2)
        return {**fields, **self.avoid(), **self.dynamics()}

    def joint_in_patch(self, kind: str, line: int) -> dict:
        link1, p1, direction = self.pair()
        link2 = self.link_ref()
        self.two_links(link1, link2, line)
        c = [self.joint_point(link2, f"patch control point P{i}") for i in range(4)]
        fields = dict(link1=link1, link2=link2, point1=p1, point2=None, axis1=direction, axis2=None,
                      patch=(c[0], c[1], c[2], c[3]))
        return {**fields, **self.avoid(), **self.dynamics()}

    def joint_bar(self, kind: str, line: int) -> dict:
        """``sph_sph``, ``sph_prs_sph``, springs and connectors: a bar, leg or cable NAME
        between a point of each link, its length or range, radius and look."""
        link1, p1, link2, p2 = self.two_points()
        self.two_links(link1, link2, line)
        fields = dict(link1=link1, link2=link2, point1=p1, point2=p2, axis1=None, axis2=None)
        numbers: dict[str, float] = {}
        if kind == "sph_sph":
            self.expect_word("length", "(the bar's length)")
            numbers["length"] = self.expr()
        elif not kind.startswith("c_"):
            self.expect_word("range", "(the bar's range of lengths [lo, hi])")
            fields["ranges"] = (self.interval(),)
        self.expect_word("radius", "(the bar's radius)")
        numbers["radius"] = self.expr()
        self.granularity()
        self.optional_color()
        self.accept_word("hidden", "decoration")
        if kind == "sph_sph":
            self.link_dynamics()
        numbers.update(self.numbers("rest", "stiffness", *_DYNAMICS))
        return {**fields, "properties": FrozenMap(numbers)}


def _defining_points(body: WorldBody, folder: Path | None) -> tuple[Vec3, ...] | None:
    """A body's points as CuikSuite numbers them: a sphere's centre; a cylinder's or line's
    two ends; a box's eight corners (z low then high, each (lo,lo) (lo,hi) (hi,hi) (hi,lo)
    in x, y); the segments' points; a body file's vertices.  ``None`` for a prism."""
    if body.kind in ("sphere", "cylinder", "line", "segments"):
        return body.points
    if body.kind == "box":
        (xl, yl, zl), (xu, yu, zu) = body.points
        return tuple((x, y, z) for z in (zl, zu) for x, y in ((xl, yl), (xl, yu), (xu, yu), (xu, yl)))
    if body.kind == "off" and body.path:
        return _off_vertices(body.path, folder)
    return None


def _off_vertices(relative: str, folder: Path | None) -> tuple[Vec3, ...]:
    """The vertices of an OFF (or COFF) body file, looked for as the importer does: in the
    world file's folder or up to three above it."""
    bases = [] if folder is None else [folder, *list(folder.parents)[:3]]
    path = next((b / relative for b in bases if (b / relative).is_file()), None)
    if path is None:
        raise Problem(f"body file {relative!r} not found (needed for a body-vertex reference)", 0)
    lines = [line.split("#")[0].split() for line in path.read_text(errors="replace").splitlines()]
    lines = [words for words in lines if words]
    if not lines or not lines[0][0].upper().endswith("OFF"):
        raise Problem(f"body file {relative!r} is not an OFF file (needed for a body-vertex reference)", 0)
    rest = lines[0][1:] and [lines[0][1:]] + lines[1:] or lines[1:]
    try:
        count = int(rest[0][0])
        return tuple((float(w[0]), float(w[1]), float(w[2])) for w in rest[1:1 + count])
    except (IndexError, ValueError):
        raise Problem(f"body file {relative!r}: cannot read its vertices", 0) from None
