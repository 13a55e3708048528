"""Hand model: rigid links joined by revolute (R) and universal (U) joints.

Follows sec. 2-3 of Rosales et al. (IJRR 2011): every link ``L_l`` carries a frame
``F_l``; a configuration assigns each link a pose ``(r_l, R_l)`` in the palm frame
``F_0`` (``x_palm = R_l x_l + r_l``, millimetres).

A joint between a parent and a child link is stated by

* ``origin_in_parent`` / ``origin_in_child``: the joint centre ``P`` (resp. ``Q``) in the
  parent (resp. child) frame [mm] (eqs. 8, 10: the two points coincide);
* ``axis_in_parent``: the first rotation axis ``u`` (parent frame, unit);
* ``axis_in_child``: for a universal joint, the second axis ``v`` (child frame, unit);
* ``R_parent_child_zero``: the child's orientation relative to the parent when every
  angle of the joint is zero.

so that the child's pose relative to its parent is

.. math::

    R_{pc}(\\theta) = \\mathrm{Rot}(u, \\theta_1)\\, R_0\\, \\mathrm{Rot}(v, \\theta_2), \\qquad
    r_{pc} = P - R_{pc} Q

(``Rot(v, theta_2)`` is absent for a revolute joint).  Both rotations are right-handed
about the stated axes.  ``R_0 v`` must be orthogonal to ``u`` (eq. 11).  Every joint
angle (a *degree of freedom*, "dof") has a name and limits ``[lower, upper]`` [rad].

Couplings state one dof as a linear function of another, as URDF ``<mimic>`` does:
``q[dof] = ratio * q[source] + offset`` (the SA hand: distal = middle, ratio 1).

Besides the kinematics a hand records what a reader needs to trust it: named frames
fixed to links (URDF links merged by fixed joints, MJCF bodies without joints), the
finger that opposes the others (:attr:`Hand.opposing_finger`), notes and warnings of its
import (:attr:`Hand.notes`), the file it came from (:attr:`Hand.source`) and the
report of each fingertip found automatically (:attr:`Hand.tip_fits`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from ..frozen import FrozenMap, cached_per_value
from typing import Literal, Mapping

import numpy as np

from ..errors import InvalidHand
from ..geometry.regions import Region
from ..geometry.vectors import unit3, vec3
from .provenance import HandSource, ShapeFit, TipFit

__all__ = ["Joint", "Coupling", "Capsule", "LinkMesh", "Link", "Finger", "HandRegion", "NamedFrame", "Hand"]

_ORTHO_TOL = 1e-6


def _limits_text(lo: float, hi: float) -> str:
    """Joint limits for a message, in degrees (what users type) and radians (what the API takes)."""
    return f"[{np.degrees(lo):.6g}, {np.degrees(hi):.6g}] deg ([{lo:.6g}, {hi:.6g}] rad)"


def _vec3(value, what: str) -> np.ndarray:
    return vec3(value, what, InvalidHand)


def _unit3(value, what: str) -> np.ndarray:
    return unit3(value, what, InvalidHand)


def _rotation(value, what: str) -> np.ndarray:
    R = np.asarray(value, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise InvalidHand(f"{what} must be a 3x3 rotation matrix, got shape {R.shape}")
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise InvalidHand(f"{what} is not a rotation matrix (R^T R != I or det(R) < 0)")
    # Re-orthonormalise rounded user numbers; leave a matrix that is already orthonormal
    # to rounding untouched, so that re-building a joint (a file round trip, a limit
    # change) never moves it.
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-13:
        u, _, vt = np.linalg.svd(R)
        R = u @ vt
    R = R.copy()
    R.setflags(write=False)
    return R


@dataclass(frozen=True, eq=False)
class Joint:
    """A revolute or universal joint (see the module docstring for the maths).

    Attributes:
        name: unique joint name.
        kind: ``"revolute"`` (1 dof) or ``"universal"`` (2 dofs).
        parent, child: link names.
        origin_in_parent: joint centre P in the parent frame [mm], shape (3,).
        origin_in_child: joint centre Q in the child frame [mm], shape (3,).
        axis_in_parent: first axis u in the parent frame (unit), shape (3,).
        R_parent_child_zero: child orientation in the parent frame at zero angles, (3, 3).
        dof_names: one name per angle: ``(theta,)`` or ``(theta_1, theta_2)``.
        lower, upper: angle limits [rad], one per dof.
        axis_in_child: second axis v in the child frame (universal only), shape (3,).
    """

    name: str
    kind: Literal["revolute", "universal"]
    parent: str
    child: str
    origin_in_parent: np.ndarray
    origin_in_child: np.ndarray
    axis_in_parent: np.ndarray
    R_parent_child_zero: np.ndarray
    dof_names: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    axis_in_child: np.ndarray | None = None

    def __post_init__(self):
        where = f"joint {self.name!r}"
        if self.kind not in ("revolute", "universal"):
            raise InvalidHand(f"{where}: kind {self.kind!r} is not supported; use 'revolute' or 'universal'")
        n = 1 if self.kind == "revolute" else 2
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        set_("origin_in_parent", _vec3(self.origin_in_parent, f"{where}: origin_in_parent"))
        set_("origin_in_child", _vec3(self.origin_in_child, f"{where}: origin_in_child"))
        set_("axis_in_parent", _unit3(self.axis_in_parent, f"{where}: axis_in_parent"))
        set_("R_parent_child_zero", _rotation(self.R_parent_child_zero, f"{where}: R_parent_child_zero"))
        set_("dof_names", tuple(self.dof_names))
        set_("lower", tuple(float(x) for x in self.lower))
        set_("upper", tuple(float(x) for x in self.upper))
        if len(self.dof_names) != n or len(self.lower) != n or len(self.upper) != n:
            raise InvalidHand(f"{where}: a {self.kind} joint has {n} angle(s); give {n} dof name(s) and limit pair(s)")
        for d, lo, hi in zip(self.dof_names, self.lower, self.upper):
            if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
                raise InvalidHand(f"{where}: limits of {d!r} must satisfy lower <= upper, got {_limits_text(lo, hi)}")
            if hi - lo > 2 * np.pi + 1e-9:
                raise InvalidHand(f"{where}: limits of {d!r} span more than one turn (360 deg): {_limits_text(lo, hi)}")
        if self.kind == "universal":
            if self.axis_in_child is None:
                raise InvalidHand(f"{where}: a universal joint needs axis_in_child (its second axis)")
            set_("axis_in_child", _unit3(self.axis_in_child, f"{where}: axis_in_child"))
            v_in_parent = self.R_parent_child_zero @ self.axis_in_child
            if abs(float(v_in_parent @ self.axis_in_parent)) > _ORTHO_TOL:
                raise InvalidHand(
                    f"{where}: the two axes of a universal joint must be orthogonal at zero angles "
                    f"(u . R0 v = {float(v_in_parent @ self.axis_in_parent):.3g})"
                )
        elif self.axis_in_child is not None:
            raise InvalidHand(f"{where}: a revolute joint has no axis_in_child")

    @property
    def n_dof(self) -> int:
        return 1 if self.kind == "revolute" else 2


@dataclass(frozen=True, eq=False)
class Coupling:
    """``q[dof] = ratio * q[source] + offset`` (angles in rad), as URDF ``<mimic>``."""

    dof: str
    source: str
    ratio: float = 1.0
    offset: float = 0.0

    def __post_init__(self):
        if self.dof == self.source:
            raise InvalidHand(f"coupling of {self.dof!r}: a dof cannot be coupled to itself")
        if not (np.isfinite(self.ratio) and np.isfinite(self.offset)):
            raise InvalidHand(f"coupling of {self.dof!r}: ratio and offset must be finite numbers")


@dataclass(frozen=True, eq=False)
class Capsule:
    """A collision capsule: all points within ``radius`` [mm] of segment a-b (link frame).

    A sphere is a capsule with ``a == b``.
    """

    a: np.ndarray
    b: np.ndarray
    radius: float

    def __post_init__(self):
        object.__setattr__(self, "a", _vec3(self.a, "capsule end a"))
        object.__setattr__(self, "b", _vec3(self.b, "capsule end b"))
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise InvalidHand(f"capsule radius must be a positive number of mm, got {self.radius}")


@dataclass(frozen=True, eq=False)
class LinkMesh:
    """A mesh file that draws a link: a reference, read only when drawn
    (:mod:`prehension.interop.scene`), never by a check or a solver.

    A point ``v`` of the file (its own units) is at ``T_link_mesh @ (scale * v)`` in the
    link frame [mm].

    Attributes:
        path: absolute path of the mesh file (any format trimesh reads).
        T_link_mesh: (4, 4) the file's frame in the link frame [mm].
        scale: (3,) mm per file unit along the file's axes (a URDF ``scale`` times the
            file's length unit).
        role: ``"visual"`` or ``"collision"``: which of the file's shapes it is.
    """

    path: str
    T_link_mesh: np.ndarray
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    role: Literal["visual", "collision"] = "visual"

    def __post_init__(self):
        T = np.array(self.T_link_mesh, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise InvalidHand(f"mesh {self.path}: T_link_mesh must be a finite 4x4 transform")
        T.setflags(write=False)
        object.__setattr__(self, "T_link_mesh", T)
        object.__setattr__(self, "scale", tuple(float(x) for x in self.scale))


@dataclass(frozen=True, eq=False)
class Link:
    """A rigid body of the hand with its collision shapes (link frame, mm).

    ``fit`` says how the capsules stand for the link's own geometry
    (:class:`~prehension.hands.provenance.ShapeFit`: what they miss, how far they stick
    out); ``None`` when they were given as they are (an inline hand, a link without shapes).
    ``meshes`` are the mesh files that draw the link (:class:`LinkMesh`: a hand file's
    visual meshes, else its collision meshes; empty for other hands): for pictures and
    scenes only.  The capsules are what every check judges, so ``meshes`` is left out of
    what identifies a task (``metadata={"digest": False}``: a checkpoint's fingerprint).
    """

    name: str
    collision: tuple[Capsule, ...] = ()
    fit: ShapeFit | None = None
    meshes: tuple[LinkMesh, ...] = field(default=(), metadata={"digest": False})

    def __post_init__(self):
        object.__setattr__(self, "collision", tuple(self.collision))
        object.__setattr__(self, "meshes", tuple(self.meshes))


@dataclass(frozen=True, eq=False)
class Finger:
    """A named chain of links from the palm outwards (``links[-1]`` is the tip link)."""

    name: str
    links: tuple[str, ...]

    def __post_init__(self):
        object.__setattr__(self, "links", tuple(self.links))
        if not self.links:
            raise InvalidHand(f"finger {self.name!r} has no links")

    @property
    def tip_link(self) -> str:
        return self.links[-1]


@dataclass(frozen=True, eq=False)
class HandRegion:
    """A contact region fixed to a hand link (region coordinates in that link's frame)."""

    link: str
    region: Region


@dataclass(frozen=True, eq=False)
class NamedFrame:
    """A frame fixed to a link (a URDF link merged by a fixed joint, an MJCF body without
    joints, an MJCF site): ``T_link_frame`` (4, 4), translation in mm."""

    link: str
    T_link_frame: np.ndarray

    def __post_init__(self):
        T = np.asarray(self.T_link_frame, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise InvalidHand(f"named frame on link {self.link!r}: T_link_frame must be a finite 4x4 transform")
        _rotation(T[:3, :3], f"named frame on link {self.link!r}: rotation")
        T = T.copy()
        T.setflags(write=False)
        object.__setattr__(self, "T_link_frame", T)

    @property
    def origin(self) -> np.ndarray:
        """The frame's origin in the link frame [mm], shape (3,)."""
        return self.T_link_frame[:3, 3]


@dataclass(frozen=True, eq=False)
class Hand:
    """A hand: a tree of links rooted at the palm, with joints, couplings and regions.

    Attributes:
        name: hand name.
        links: every link, the palm first.
        joints: joints in an order where each parent link is placed before its child.
        couplings: linear couplings between dofs.
        fingers: named finger chains (used to pick the dofs a task moves).
        regions: named contact regions on links.
        collision_exclusions: link pairs never checked for collision, besides the
            pairs joined by a joint (always excluded).
        frames: named frames fixed to links (see :class:`NamedFrame`); a frame name is
            not a link name, but naming one where a link is expected gets a hint.
        opposing_finger: the finger that opposes the others (a thumb): the local solver
            places the object from its contact.  Default: the finger named ``"thumb"``,
            if there is one, else none.
        notes: what the import of the hand noted or warned about (palm cut from an arm,
            missing meshes, unsupported joints held fixed, frames merged...).
        source: the hand file the hand was read from (None: built in code or inline).
        tip_fits: per fingertip region name, how it was found (:class:`TipFit`).
    """

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    couplings: tuple[Coupling, ...] = ()
    fingers: tuple[Finger, ...] = ()
    regions: Mapping[str, HandRegion] = field(default_factory=dict)
    collision_exclusions: tuple[tuple[str, str], ...] = ()
    frames: Mapping[str, NamedFrame] = field(default_factory=dict)
    opposing_finger: str | None = None
    notes: tuple[str, ...] = ()
    source: HandSource | None = None
    tip_fits: Mapping[str, TipFit] = field(default_factory=dict)

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        for attr in ("links", "joints", "couplings", "fingers", "notes"):
            set_(attr, tuple(getattr(self, attr)))
        for attr in ("regions", "frames", "tip_fits"):
            set_(attr, FrozenMap(dict(getattr(self, attr))))
        set_("collision_exclusions", tuple(tuple(p) for p in self.collision_exclusions))
        if self.opposing_finger is None and any(f.name == "thumb" for f in self.fingers):
            set_("opposing_finger", "thumb")
        from ._validate import validate_hand  # local: keeps this module about data

        validate_hand(self)

    # -- names and indices ----------------------------------------------------------
    @property
    def palm(self) -> str:
        return self.links[0].name

    @cached_property  # the hand is immutable: computed once
    def link_names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @cached_property  # the hand is immutable: computed once
    def dof_names(self) -> tuple[str, ...]:
        return tuple(d for j in self.joints for d in j.dof_names)

    @cached_property  # the hand is immutable: computed once
    def n_dof(self) -> int:
        return len(self.dof_names)

    def link_index(self, name: str) -> int:
        try:
            return self.link_names.index(name)
        except ValueError:
            raise InvalidHand(self.missing_link_message(name)) from None

    def missing_link_message(self, name: str) -> str:
        """Why ``name`` is not a link: a hint when it is a named frame, else the links."""
        frame = self.frames.get(name)
        if frame is not None:
            at = ", ".join(f"{x:.6g}" for x in frame.origin)
            return (
                f"link {name!r} not found: it is a frame fixed to link {frame.link!r} (merged at import), "
                f"with its origin at [{at}] mm in that link's frame; name link {frame.link!r} instead"
            )
        return f"link {name!r} not found; links are: {', '.join(self.link_names)}"

    def dof_index(self, name: str) -> int:
        try:
            return self.dof_names.index(name)
        except ValueError:
            raise InvalidHand(f"joint angle {name!r} not found; angles are: {', '.join(self.dof_names)}") from None

    def finger(self, name: str) -> Finger:
        for f in self.fingers:
            if f.name == name:
                return f
        names = ", ".join(f.name for f in self.fingers) or "(none defined)"
        raise InvalidHand(f"finger {name!r} not found; fingers are: {names}")

    def region(self, name: str) -> HandRegion:
        try:
            return self.regions[name]
        except KeyError:
            names = ", ".join(self.regions) or "(none defined)"
            raise InvalidHand(f"hand region {name!r} not found; regions are: {names}") from None

    @property
    def lower(self) -> np.ndarray:
        """Lower angle limits [rad], shape (n_dof,)."""
        return np.array([lo for j in self.joints for lo in j.lower])

    @property
    def upper(self) -> np.ndarray:
        """Upper angle limits [rad], shape (n_dof,)."""
        return np.array([hi for j in self.joints for hi in j.upper])

    def joint_of_link(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (``None`` for the palm)."""
        for j in self.joints:
            if j.child == link:
                return j
        return None

    def chain_dofs(self, link: str) -> tuple[int, ...]:
        """Indices of the dofs that move ``link`` (its ancestors' joints), palm first."""
        out: list[int] = []
        offsets = self.dof_offsets
        joint = self.joint_of_link(link)
        while joint is not None:
            k = self.joints.index(joint)
            out[:0] = range(offsets[k], offsets[k] + joint.n_dof)
            joint = self.joint_of_link(joint.parent)
        return tuple(out)

    @cached_property  # the hand is immutable: computed once
    def dof_offsets(self) -> tuple[int, ...]:
        """Index of each joint's first dof in the dof vector."""
        offs, k = [], 0
        for j in self.joints:
            offs.append(k)
            k += j.n_dof
        return tuple(offs)

    def finger_of_link(self, link: str) -> str | None:
        for f in self.fingers:
            if link in f.links:
                return f.name
        return None

    def active_dofs(self, fingers) -> np.ndarray:
        """(n_dof,) bool: the dofs that move the links of ``fingers``, closed under couplings.

        A dof moves a link when its joint is the link's or an ancestor's.  A coupled dof
        that moves brings its source along, and a source that moves brings every dof
        coupled to it (on the Schunk SVH the index's spread is coupled to the little
        finger's, so a task with the index moves both spreads).
        """
        mask = np.zeros(self.n_dof, dtype=bool)
        for f in fingers:
            for link in self.finger(f).links:
                mask[list(self.chain_dofs(link))] = True
        index = {d: i for i, d in enumerate(self.dof_names)}
        for c in self.couplings:  # sources are never coupled: two passes close the set
            if mask[index[c.dof]]:
                mask[index[c.source]] = True
        for c in self.couplings:
            if mask[index[c.source]]:
                mask[index[c.dof]] = True
        return mask

    def with_regions(self, extra: Mapping[str, HandRegion]) -> "Hand":
        """A copy of this hand with more (or replaced) named regions."""
        merged = dict(self.regions)
        merged.update(extra)
        return _replace(self, regions=merged)

    def with_limits(self, limits: Mapping[str, tuple[float, float]]) -> "Hand":
        """A copy with the limits of the named dofs replaced (``{dof: (lower, upper)}`` rad)."""
        unknown = set(limits) - set(self.dof_names)
        if unknown:
            raise InvalidHand(
                f"limits given for unknown joint angle(s) {sorted(unknown)}; angles are: {', '.join(self.dof_names)}"
            )
        joints = []
        for j in self.joints:
            lo = tuple(limits.get(d, (l, h))[0] for d, l, h in zip(j.dof_names, j.lower, j.upper))
            hi = tuple(limits.get(d, (l, h))[1] for d, l, h in zip(j.dof_names, j.lower, j.upper))
            joints.append(_replace(j, lower=lo, upper=hi))
        return _replace(self, joints=tuple(joints))

    def without_couplings(self) -> "Hand":
        return _replace(self, couplings=())


def _replace(obj, **changes):
    from dataclasses import replace

    return replace(obj, **changes)


# -- derived tables (a weak cache keyed by the Hand, never written onto it) ---------------
def _tree_tables(hand: Hand) -> dict:
    """Index tables the batch kinematics needs, computed once per hand."""
    names = hand.link_names
    parent_of_joint = np.array([names.index(j.parent) for j in hand.joints])
    child_of_joint = np.array([names.index(j.child) for j in hand.joints])
    moves = np.zeros((len(names), hand.n_dof), dtype=bool)  # moves[l, d]: dof d moves link l
    for link in names:
        moves[names.index(link), list(hand.chain_dofs(link))] = True
    return {"parent": parent_of_joint, "child": child_of_joint, "moves": moves}


@cached_per_value
def tree_tables(hand: Hand) -> dict:
    """The hand's derived index tables (see :func:`_tree_tables`), built once per hand and
    held beside it (a weak cache: they go with the hand).  Other modules keep their own
    per-hand tables the same way (:func:`prehension.frozen.cached_per_value`)."""
    return _tree_tables(hand)
