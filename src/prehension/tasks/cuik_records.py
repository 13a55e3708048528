"""The records a parsed CuikSuite ``.world`` file is made of (plain, frozen, as written).

:mod:`prehension.tasks.cuik_parser` builds them; :mod:`prehension.tasks.cuik_import` gives
them their meaning.  Points, displacements and reference vectors are kept as written
(after evaluating their expressions), in the frame of the link they are written for.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Union

from ..frozen import FrozenMap
from .cuik_expressions import Vec3

__all__ = [
    "Vec3", "Color", "COLOR_RGB", "WorldBody", "WorldLink", "WorldJoint", "WorldCollision",
    "WorldFile", "JOINT_KINDS", "IMPORTED_JOINTS",
]

Color = Union[str, Vec3]

# CuikSuite's named colours (its RGB values, needed by colour arithmetic such as 0.75*red)
COLOR_RGB: dict[str, Vec3] = {
    "red": (1.0, 0.0, 0.0), "green": (0.0, 1.0, 0.0), "blue": (0.0, 0.0, 1.0),
    "black": (0.0, 0.0, 0.0), "grey": (0.7, 0.7, 0.7), "white": (1.0, 1.0, 1.0),
    "yellow": (1.0, 1.0, 0.0), "purple": (1.0, 0.0, 1.0), "cyan": (0.0, 1.0, 1.0),
}

# every joint kind of the language; the first four (and crevolute, fix) import into a task
JOINT_KINDS = (
    "revolute", "universal", "spherical", "in_patch", "crevolute", "fix", "prismatic",
    "sph_sph", "sph_prs_sph", "spring", "xyspring", "c_cable", "c_spring", "c_leg",
)
IMPORTED_JOINTS = ("revolute", "crevolute", "universal", "fix", "spherical", "in_patch")


@dataclass(frozen=True)
class WorldBody:
    """One body of a link (or an obstacle), as written (display shapes: not interpreted).

    ``kind`` is ``"off"`` (``body "file.off"``; ``path`` is the file name as written,
    relative to the world file), ``"sphere"`` (``radius``, ``points = (centre,)``),
    ``"cylinder"`` (``radius``, ``points = (end1, end2)``), ``"box"``
    (``points = (corner1, corner2)``), ``"line"`` (``points = (end1, end2)``), ``"prism"``
    (``points`` = three base points, ``radius`` = its height) or ``"segments"`` (``points``:
    the polyline); a ``+(...)`` second point is resolved to an absolute one.  ``color`` is
    the body's colour, or the link's when the body states none (a name such as ``"white"``,
    or an RGB triple, e.g. for ``0.75*red``); ``status`` is ``"hidden"``, ``"decoration"``
    or ``None``.
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
    """A link (or an obstacle): its name, the line of the name, its default colour and its
    bodies; ``end_effector`` when written ``NAME - ...`` rather than ``NAME: ...``;
    ``mass`` when given (the inertia and inertial frame are read, not kept)."""

    name: str
    line: int
    bodies: tuple[WorldBody, ...] = ()
    color: Color | None = None
    end_effector: bool = False
    mass: float | None = None


@dataclass(frozen=True)
class WorldJoint:
    """One joint statement of ``[JOINTS]``, with every expression evaluated.

    * ``kind``: one of :data:`JOINT_KINDS`; ``line``: the line of the joint keyword;
      ``name``: the name a ``sph_sph``/``sph_prs_sph``/spring/connector joint gives its bar.
    * ``point1`` / ``point2``: the joint point written for ``link1`` / ``link2`` (each in
      its link's frame; a body-vertex reference ``N`` or ``B:N`` is resolved to the point);
      ``point2`` is ``None`` for ``in_patch`` and ``fix``.
    * ``axis1`` / ``axis2``: the displacement written after ``point1`` / ``point2``
      (``+(d)`` is stored as ``d``; a plain second point ``(q)`` as ``q - point``).
      Revolute, crevolute, universal and prismatic have both; ``in_patch`` has ``axis1``
      (its direction); the others neither.
    * ``ranges``: ``((lo, hi),)`` for a (c)revolute, prismatic, sph_prs_sph or spring joint,
      ``((lo1, hi1), (lo2, hi2))`` for a universal joint, ``()`` without ``range``.
    * ``cone_angle``: the ``range [beta]`` of a spherical joint, else ``None``.
    * ``range_vectors``: the two reference vectors as written -- revolute ``(a, b)``,
      universal ``(a1, a2)``, spherical ``(m, n)`` -- the first relative to ``point1``,
      the second to ``point2``; ``()`` when none are given.
    * ``patch``: the four ``in_patch`` control points in the order written, else ``None``.
    * ``transform``: a ``fix`` joint's 4x4 transform taking ``link2``'s frame into
      ``link1``'s (``x1 = T x2``), rows, else ``None``.
    * ``avoid_limits`` and its optional weight ``avoid_limits_weight``.
    * ``properties``: the other numbers written (``length``, ``radius``, ``rest``,
      ``stiffness``, ``velocity``, ``acceleration``, ``effort``, ``cost``, ``friction``,
      ``damping``), by keyword.
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
    name: str | None = None
    transform: tuple[tuple[float, ...], ...] | None = None
    properties: Mapping[str, float] = field(default_factory=lambda: FrozenMap({}))


@dataclass(frozen=True)
class WorldCollision:
    """A ``[COLLISIONS]`` statement: ``check`` (or ``do not check``) ``what``: ``"all"``,
    ``"selfcollisions"``, ``"connected"``, or one or two link/obstacle names."""

    check: bool
    what: tuple[str, ...]
    line: int


@dataclass(frozen=True)
class WorldFile:
    """A parsed world: evaluated constants (read-only mappings), links, joints, and the
    obstacles, collision statements and equation files (``(file, line)``) it states.
    Included files are merged in, their names prefixed ``INCLUDE__``."""

    path: str | None
    constants: Mapping[str, float]
    constant_lines: Mapping[str, int]
    links: tuple[WorldLink, ...]
    joints: tuple[WorldJoint, ...]
    obstacles: tuple[WorldLink, ...] = ()
    collisions: tuple[WorldCollision, ...] = ()
    equations: tuple[tuple[str, int], ...] = ()

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
