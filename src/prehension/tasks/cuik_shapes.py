"""The CuikSuite world language's bodies, colours, link dynamics and transforms.

The statement reader of :mod:`prehension.tasks.cuik_parser` builds on this one (its
docstring has the whole grammar); these are the pieces a link, an obstacle and some
joints share: ``shape``, ``colour``, ``dynamics`` and ``transforms``.
"""

from __future__ import annotations

import math

from .cuik_expressions import FUNCTIONS, ExpressionReader, Token, Vec3
from .cuik_records import COLOR_RGB, JOINT_KINDS, Color, WorldBody

__all__ = ["ShapeReader", "KEYWORDS", "SHAPES"]

SHAPES = ("body", "box", "prism", "sphere", "cylinder", "line", "segments")
_STATUS = ("hidden", "decoration")
_INERTIA_SHAPES = ("rod_x", "rod_y", "rod_z", "cylinder_x", "cylinder_y", "cylinder_z", "sphere",
                   "box", "ellipsoid", "solid")
_TRANSFORMS = ("id", "tx", "ty", "tz", "txyz", "rx", "ry", "rz", "tr")

# every word CuikSuite's lexer reads as a keyword (case-insensitively): never a name
KEYWORDS = frozenset(
    {"pi", "parameter", "print", "granularity", "mass", "inertial", "frame", "inertia", "matrix",
     "velocity", "acceleration", "torque", "force", "effort", "cost", "friction", "damping",
     "rest", "stiffness", "length", "radius", "color", "range", "reference", "check", "all",
     "connected", "selfcollisions", "avoid", "limits", "eqfile"}
    | set(COLOR_RGB) | set(SHAPES) | set(_STATUS) | set(_INERTIA_SHAPES) | set(_TRANSFORMS)
    | set(FUNCTIONS) - {"log"} | set(JOINT_KINDS)
)  # section names are no keywords: "[LINKS]" is one token in CuikSuite, a link may be called "links"


def _product(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def _inverse(t: list[list[float]]) -> list[list[float]]:
    """The inverse of a rigid transform (rotation transposed)."""
    r = [[t[j][i] for j in range(3)] for i in range(3)]
    p = [-sum(r[i][k] * t[k][3] for k in range(3)) for i in range(3)]
    return [r[0] + [p[0]], r[1] + [p[1]], r[2] + [p[2]], [0.0, 0.0, 0.0, 1.0]]


def _elementary(kind: str, args: list[float]) -> list[list[float]]:
    t = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    if kind in ("tx", "ty", "tz", "txyz"):
        offsets = args if kind == "txyz" else [args[0] if kind == f"t{a}" else 0.0 for a in "xyz"]
        for i in range(3):
            t[i][3] = offsets[i]
    elif kind in ("rx", "ry", "rz"):
        c, s = math.cos(args[0]), math.sin(args[0])
        i, j = {"rx": (1, 2), "ry": (2, 0), "rz": (0, 1)}[kind]
        t[i][i], t[i][j], t[j][i], t[j][j] = c, -s, s, c
    return t


class ShapeReader(ExpressionReader):
    """Reads shapes, colours, link dynamics and transforms (over :class:`ExpressionReader`)."""

    # -- colours
    def starts_color(self, ahead: int = 0) -> bool:
        """A colour starts here: a colour word, or ``NUMBER *`` before one."""
        while self.peek(ahead).kind == "num" and self.peek(ahead + 1).is_op("*"):
            ahead += 2
        return self.peek(ahead).is_word("color", *COLOR_RGB)

    def optional_color(self) -> Color | None:
        """``colour := term ("+" term)*``, ``term := NUMBER "*" term | NAME | color(r,g,b)``
        (CuikSuite's colour arithmetic: a scaled colour, a sum of colours).  A plain name
        stays a name; anything computed is an RGB triple."""
        if not self.starts_color():
            return None
        color = self.color_term()
        while self.peek().is_op("+") and self.starts_color(1):
            self.advance()
            other = self.color_term()
            color = tuple(a + b for a, b in zip(_rgb(color), _rgb(other)))  # type: ignore[assignment]
        return color

    def color_term(self) -> Color:
        token = self.peek()
        if token.kind == "num":
            self.advance()
            self.expect_op("*", "after a colour's scale factor")
            scale = float(token.text)
            return tuple(scale * c for c in _rgb(self.color_term()))  # type: ignore[return-value]
        if token.is_word("color"):
            self.advance()
            return self.point("an RGB colour")
        if token.is_word(*COLOR_RGB):
            self.advance()
            return token.text.lower()
        self.fail(f"expected a colour (a name such as red, color(r,g,b), or a scaled colour such as "
                  f"0.5*red), found {token.describe()}")

    # -- shapes
    def shape(self, link_color: Color | None) -> WorldBody:
        """One body: ``body "f.off"``, ``box``, ``prism``, ``sphere``, ``cylinder``, ``line``,
        ``segments``, each with its optional colour, granularity and status."""
        token = self.advance()
        kind = token.text.lower()
        fields: dict = {"kind": kind, "line": token.line}
        if kind == "body":
            path = self.peek()
            if path.kind != "str":
                self.fail(f"expected a quoted file name after 'body', found {path.describe()}")
            self.advance()
            fields.update(kind="off", path=path.text[1:-1])
        elif kind == "sphere":
            fields.update(radius=self.expr(), points=(self.point("the sphere centre"),))
        elif kind == "prism":
            points = tuple(self.point(f"prism point {i + 1}") for i in range(3))
            fields.update(points=points, radius=self.expr())
        elif kind == "segments":
            fields["points"] = self.point_list()
        else:
            if kind == "cylinder":
                fields["radius"] = self.expr()
            first = self.point(f"the first {kind} point")
            d = self.displacement(first, f"the second {kind} point")
            fields["points"] = (first, (first[0] + d[0], first[1] + d[1], first[2] + d[2]))
        color = self.optional_color()
        fields["color"] = color if color is not None else link_color
        if kind in ("off", "body", "sphere", "cylinder"):
            fields["granularity"] = self.granularity()
        if kind != "segments" and self.peek().is_word(*_STATUS):
            fields["status"] = self.advance().text.lower()
        return WorldBody(**fields)

    def granularity(self) -> int | None:
        if not self.accept_word("granularity"):
            return None
        token = self.peek()
        if token.kind != "num" or not token.text.isdigit():
            self.fail(f"expected an integer after 'granularity', found {token.describe()}")
        self.advance()
        return int(token.text)

    def point_list(self) -> tuple[Vec3, ...]:
        """``(x,y,z; x,y,z; ...)``: the points of ``segments``."""
        opened = self.expect_op("(", "to start the segments' points (x,y,z; x,y,z; ...)")
        points = []
        while True:
            xyz = [self.expr()]
            for _ in range(2):
                self.expect_op(",", f"between coordinates in the point list opened at line {opened.line}")
                xyz.append(self.expr())
            points.append((xyz[0], xyz[1], xyz[2]))
            if not self.peek().is_op(";"):
                break
            self.advance()
        self.expect_op(")", f"to close the point list opened at line {opened.line}")
        return tuple(points)

    # -- link dynamics (read; only the mass is kept)
    def link_dynamics(self) -> float | None:
        mass = self.expr() if self.accept_word("mass") else None
        if self.accept_word("inertia"):
            self.expect_word("matrix", "after 'inertia'")
            self.inertia()
        if self.accept_word("inertial"):
            self.expect_word("frame", "after 'inertial'")
            self.transforms()
        return mass

    def inertia(self) -> None:
        """``e,e,e,e,e,e`` or a shape: ``rod_x e``, ``cylinder_x e,e,e``, ``solid cylinder_x
        e,e``, ``sphere e``, ``solid sphere e``, ``box e,e,e``, ``ellipsoid e,e,e``."""
        solid = self.accept_word("solid")
        token = self.peek()
        word = token.text.lower() if token.kind == "id" else ""
        if word in _INERTIA_SHAPES:
            self.advance()
            count = 1 if word.startswith("rod") or word == "sphere" else 3
            count -= 1 if solid and word.startswith("cylinder") else 0
        elif solid:
            self.fail(f"expected cylinder_x/y/z or sphere after 'solid', found {token.describe()}")
        else:
            count = 6
        self.comma_exprs(count, "the inertia matrix")

    def comma_exprs(self, count: int, what: str) -> list[float]:
        values = [self.expr()]
        for _ in range(count - 1):
            self.expect_op(",", f"between the numbers of {what}")
            values.append(self.expr())
        return values

    # -- transforms
    def transforms(self) -> tuple[tuple[float, ...], ...]:
        """``transform ("*" transform)*``, composed left to right (``Tx(a)*Rz(b)`` translates,
        then turns about the translated z); ``TR(12 numbers in rows separated by ';')``,
        optionally ``^-1``."""
        total = _elementary("id", [])
        while True:
            total = _product(total, self.transform())
            if not self.peek().is_op("*"):
                return tuple(tuple(row) for row in total)
            self.advance()

    def transform(self) -> list[list[float]]:
        token = self.peek()
        word = token.text.lower() if token.kind == "id" else ""
        if word not in _TRANSFORMS:
            self.fail(f"expected a transform (Id, Tx(a), Ty, Tz, Txyz(x,y,z), Rx(a), Ry, Rz, TR(...)), "
                      f"found {token.describe()}")
        self.advance()
        if word == "id":
            return _elementary("id", [])
        opened = self.expect_op("(", f"after '{token.text}'")
        if word != "tr":
            args = self.comma_exprs(3 if word == "txyz" else 1, f"'{token.text}'")
            self.expect_op(")", f"to close '{token.text}(' opened at line {opened.line}")
            return _elementary(word, args)
        rows = [self.comma_exprs(4, "a TR row")]
        for _ in range(2):
            self.expect_op(";", "between the rows of TR(...)")
            rows.append(self.comma_exprs(4, "a TR row"))
        self.expect_op(")", f"to close 'TR(' opened at line {opened.line}")
        t = rows + [[0.0, 0.0, 0.0, 1.0]]
        if self.peek().is_op("^") and self.peek(1).is_op("-") and self.peek(2).text == "1":
            self.pos += 3
            t = _inverse(t)
        return t

    def name_token(self, kind: str) -> Token:
        """A new name (of a constant, link, obstacle, include...): not a keyword."""
        token = self.peek()
        if token.kind != "id":
            self.fail(f"expected a {kind} name, found {token.describe()}")
        if token.text.lower() in KEYWORDS:
            self.fail(f"'{token.text}' is a keyword and cannot be used as a {kind} name")
        return self.advance()


def _rgb(color: Color) -> Vec3:
    return COLOR_RGB[color] if isinstance(color, str) else color
