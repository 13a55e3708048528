"""The grasp problem as a polynomial system of special form (Rosales et al. 2011, sec. 3).

``build_system(task)`` returns a :class:`Formulation`: the canonical :class:`System` of
eq. 29 and the bookkeeping that maps its points to and from task configurations.

Choices (each keeps the system exact; see ``docs/complete-solver.md``):

* **The object frame is the absolute frame.**  The paper takes the palm; taking the
  object makes every object point and normal *constant or Bernstein* in the object's own
  coordinates (no rotation products on the object side), and the palm becomes a link with
  a free pose ``(R_object_palm, p_palm_in_object)``.  Below, ``R_l`` is short for
  ``R_object_l`` (``x_object = R_object_l x_l``) and ``r_0`` for ``p_palm_in_object``;
  each base variable carries a typed key (:mod:`.keys`).
* **Link rotations** ``R_l = (c, d, e)`` are 9 variables per link with eqs. 4-7, plus the
  redundant unit-column ``|e| = 1`` and unit-row identities (they tighten the linear
  relaxations at no risk).
* **Positions are eliminated** (the loop closure of sec. 3.5): a link's origin is
  ``r_0 + sum over its chain of (R_parent P - R_child Q)``, linear in rotation entries.
* **Joints**: revolute ``R_p u = R_c v`` (eq. 9, linear); universal
  ``(R_p u) . (R_c v) = 0`` (eq. 11).  **Limits** (sec. 3.3): every joint angle ``theta`` is
  the angle about an axis ``w`` from a vector ``a`` to a vector ``b`` fixed in the two
  links: ``cos theta = a . b``, ``sin theta = (w x a) . b``, and the range
  ``[mid - h, mid + h]`` is ``cos(mid) cos theta + sin(mid) sin theta >= cos h`` (linear).
  **Couplings** ``theta_d = r theta_s + o`` (:mod:`.couplings`): with ``r = +-1`` linear
  in these cosines and sines (sec. 5.1 equates them), with any simple rational ``r = p/q``
  polynomial (multiple-angle identities), and for every ratio an angle coupling that the
  solver enforces by interval reasoning on the angles.
* **Contacts** (eqs. 15-25): the object point ``o = f(s, t)`` and the normal patch
  ``N = g(s, t)`` are Bernstein forms (eq. 32); ``N = mu nu`` with ``|nu| = 1`` and
  ``mu >= 0`` makes ``nu`` the unit outward normal.  A fingertip sphere cap gives
  ``r_k + R_k c - rho nu = o`` and the cone ``-nu . (R_k m) >= cos(beta)``; a point region
  ``r_k + R_k p = o``, ``R_k n = -nu``; a hand Bézier patch the same with Bernstein forms
  in the link frame.
* **Quaternions** (only when asked: ``build_system(task, quaternions="palm" | "links")``):
  the unit quaternion ``q = (w, x, y, z)``, ``w >= 0``, of the palm's rotation (or of every
  link's) as four more base variables with ``|q|^2 = 1`` and ``R = R(q)`` (each entry
  quadratic in ``q``), so that the search can halve a rotation by one split
  (docs/complete-solver.md, "Quaternion and angle branching").  With ``angles=True`` each joint angle
  ``theta`` of half range ``h < 90 deg`` also gets ``sin(theta - mid) = cos(mid) sin theta -
  sin(mid) cos theta`` (linear in the system's cosine and sine), in ``[-sin h, sin h]`` and
  monotone over the range: splitting it at 0 halves the angle's range.

Only the links on the paths from the palm to the contact links enter the system (the
paper removes fingers outside the kinematic loops); the other angles are fixed when a
point of the system is turned back into a configuration.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..hands.model import Joint
from ..hands.reach import span_bound_mm
from ..tasks.model import Task
from .builder import Builder, Lin, lin_sum
from .canonical import System
from .couplings import add_coupling
from .keys import BaseKey, ContactVariables, PalmOrigin, QuaternionComponent, RotationEntry, Side, UnitNormal
from .regions import form_of

__all__ = ["Formulation", "DofAngle", "QUATERNIONS", "build_system"]

#: Which link rotations :func:`build_system` gives quaternion variables: none, the palm's, every link's.
QUATERNIONS = ("none", "palm", "links")


@dataclass(frozen=True)
class DofAngle:
    """A joint angle: the angle about ``w`` from ``a`` to ``b`` (vectors in link frames)."""

    dof: str
    link_a: str
    a: np.ndarray
    link_b: str
    b: np.ndarray
    link_w: str
    w: np.ndarray
    mid: float  # middle of the range [rad]
    half_range: float  # half its width [rad]


@dataclass(frozen=True, eq=False)
class Formulation:
    """The system of a task and the maps between its points and configurations.

    Everything is in the **object frame** (see the module docstring).

    Attributes:
        task: the task.
        system: its canonical system.
        links: the links in the system, palm first.
        R_object_link: link -> ``(3, 3)`` variable indices of ``R_object_link``
            (``x_object = R_object_link x_link``).
        p_palm_in_object: ``(3,)`` variable indices of the palm origin in the object frame [mm].
        dof_vars: dof -> ``(cos theta, sin theta)`` variable indices.
        contact_vars: per contact, the variables a configuration is read back from.
        base_keys: index of every base variable -> its typed key (:mod:`.keys`).
        builder: the builder, which knows how every other variable follows from the base ones.
        quaternion_vars: link -> ``(4,)`` variable indices of the unit quaternion ``(w, x, y, z)``,
            ``w >= 0``, of ``R_object_link`` (only the links given quaternions, see ``build_system``).
        angle_vars: dof -> index of ``sin(theta - mid)`` (only with ``build_system(..., angles=True)``).
    """

    task: Task
    system: System
    links: tuple[str, ...]
    R_object_link: dict[str, np.ndarray]
    p_palm_in_object: np.ndarray
    dof_vars: dict[str, tuple[int, int]]
    contact_vars: tuple[ContactVariables, ...]
    base_keys: dict[int, BaseKey]
    builder: Builder = field(repr=False)
    quaternion_vars: dict[str, np.ndarray] = field(default_factory=dict)
    angle_vars: dict[str, int] = field(default_factory=dict)

    @property
    def dofs_in_system(self) -> tuple[str, ...]:
        return tuple(self.dof_vars)

    @cached_property
    def base_indices(self) -> np.ndarray:
        """``(n_base,)`` sorted indices of the base variables (the ones worth splitting)."""
        return np.array(sorted(self.base_keys), dtype=int)


# -- which links, which angles ----------------------------------------------------------
def _contact_links(task: Task) -> list[str]:
    return [task.hand_region(c).link for c in task.contacts]


def _loop_joints(task: Task) -> list[Joint]:
    """Joints on the paths from the palm to the contact links, palm outwards."""
    needed: set[str] = set()
    for link in _contact_links(task):
        joint = task.hand.joint_of_link(link)
        while joint is not None:
            needed.add(joint.name)
            joint = task.hand.joint_of_link(joint.parent)
    return [j for j in task.hand.joints if j.name in needed]


def dof_angles(joint: Joint) -> list[DofAngle]:
    """Each angle of a joint as the angle about ``w`` from ``a`` to ``b`` (link frames).

    Frame axes are preferred for ``a`` and ``b``, so that their object-frame vectors are rotation
    columns already in the system and no new variable is needed.
    """
    u = joint.axis_in_parent
    R0 = joint.R_parent_child_zero
    if joint.kind == "revolute":
        a = _perpendicular(u)
        specs = [(joint.parent, a, joint.child, R0.T @ a, joint.parent, u)]
    else:
        v = joint.axis_in_child
        specs = [
            (joint.parent, R0 @ v, joint.child, v, joint.parent, u),  # theta_1 about u
            (joint.parent, u, joint.child, R0.T @ u, joint.child, v),  # theta_2 about v
        ]
    return [
        DofAngle(dof, la, a, lb, b, lw, w, 0.5 * (lo + hi), 0.5 * (hi - lo))
        for dof, lo, hi, (la, a, lb, b, lw, w) in zip(joint.dof_names, joint.lower, joint.upper, specs)
    ]


def _perpendicular(u: np.ndarray) -> np.ndarray:
    """A unit vector orthogonal to ``u``: a frame axis when ``u`` is one."""
    for axis in np.eye(3):
        if abs(axis @ u) < 1e-12:
            return axis
    helper = np.eye(3)[int(np.argmin(np.abs(u)))]
    p = np.cross(u, helper)
    return p / np.linalg.norm(p)


# -- the builder steps ------------------------------------------------------------------
class _Formulator:
    def __init__(self, task: Task):
        self.task = task
        self.b = Builder()
        self.R_object_link: dict[str, np.ndarray] = {}
        self.base_keys: dict[int, BaseKey] = {}
        self.origins: dict[str, list[Lin]] = {}  # link -> its origin in the object frame
        self.dof_vars: dict[str, tuple[int, int]] = {}
        self.contact_vars: list[ContactVariables] = []
        self.angles: dict[str, DofAngle] = {}
        self.object_points: list[list[Lin]] = []
        self.reach_points: list[list[Lin]] = []  # per contact: the centre of its hand ball
        self.p_palm_in_object = np.zeros(3, dtype=int)
        self.quaternion_vars: dict[str, np.ndarray] = {}
        self.angle_vars: dict[str, int] = {}

    def base(self, key: BaseKey, name: str, lo: float, hi: float) -> int:
        i = self.b.var(name, lo, hi)
        self.base_keys[i] = key
        return i

    # rotations ------------------------------------------------------------------
    def add_link(self, link: str) -> None:
        idx = np.array(
            [[self.base(RotationEntry(link, r, c), f"R_object_{link}[{r},{c}]", -1.0, 1.0) for c in range(3)]
             for r in range(3)]
        )  # fmt: skip
        self.R_object_link[link] = idx
        self._orthonormal(idx)

    def _orthonormal(self, R: np.ndarray) -> None:
        b = self.b
        sq = np.vectorize(b.square)(R)
        one = Lin.constant(1.0)
        for k in range(3):
            b.equation(lin_sum(Lin.var(sq[r, k]) for r in range(3)) - one)  # unit columns (4, 5)
            b.equation(lin_sum(Lin.var(sq[k, c]) for c in range(3)) - one)  # unit rows (redundant)
        cols = [[(R[r, c], 1.0) for r in range(3)] for c in range(3)]
        b.equation(b.dot(cols[0], cols[1]))  # orthogonal columns (6)
        c, d = cols[0], cols[1]
        for r in range(3):  # e = c x d (7)
            r1, r2 = (r + 1) % 3, (r + 2) % 3
            b.equation(b.bilinear(c[r1], d[r2]) - b.bilinear(c[r2], d[r1]) - Lin.var(R[r, 2]))

    def add_quaternion(self, link: str) -> None:
        """The unit quaternion ``q = (w, x, y, z)`` of ``R_link``, ``w >= 0`` (every rotation has
        one: ``q`` and ``-q`` give the same rotation), with ``|q|^2 = 1`` and ``R = R(q)``:
        ``R_ii = w^2 + q_i^2 - q_j^2 - q_k^2`` and ``R_ij = 2 (q_i q_j - e_ijk w q_k)`` (``q_1..q_3 =
        x, y, z``; ``e`` the Levi-Civita symbol), linear in the squares and products of ``q``."""
        b, R = self.b, self.R_object_link[link]
        q = [self.base(QuaternionComponent(link, k), f"q_{link}[{k}]", 0.0 if k == 0 else -1.0, 1.0) for k in range(4)]
        self.quaternion_vars[link] = np.array(q)
        sq = [Lin.var(b.square(i)) for i in q]
        b.equation(lin_sum(sq) - Lin.constant(1.0))
        for r in range(3):
            for c in range(3):
                if r == c:
                    value = lin_sum(sq[k + 1] * (1.0 if k == r else -1.0) for k in range(3)) + sq[0]
                else:
                    k = 3 - r - c
                    levi = 1.0 if (r, c, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
                    value = b.bilinear((q[r + 1], 2.0), (q[c + 1], 1.0)) - b.bilinear((q[0], 2.0 * levi), (q[k + 1], 1.0))
                b.equation(value - Lin.var(R[r, c]))

    def add_angle_offset(self, dof: str) -> None:
        """``sin(theta - mid)`` of an angle of half range ``h < pi / 2``: in ``[-sin h, sin h]``
        (padded by 1e-12: a limit reached exactly stays inside after rounding)."""
        ang, (cos_i, sin_i) = self.angles[dof], self.dof_vars[dof]
        if ang.half_range >= 0.5 * np.pi:
            return
        offset = Lin.var(sin_i, np.cos(ang.mid)) - Lin.var(cos_i, np.sin(ang.mid))
        bound = np.sin(ang.half_range) + 1e-12
        self.angle_vars[dof] = self.b.as_var_bounded(offset, f"sin({dof} - mid)", -bound, bound)

    def in_object(self, link: str, v) -> list[Lin]:
        """``R_object_link v``: a vector fixed in ``link``, in the object frame (linear)."""
        R = self.R_object_link[link]
        return [lin_sum(Lin.var(R[r, c], float(v[c])) for c in range(3) if v[c] != 0.0) for r in range(3)]

    def in_object_vars(self, link: str, v, name: str) -> list[tuple[int, float]]:
        return [self.b.as_var(e, f"{name}[{r}]") for r, e in enumerate(self.in_object(link, v))]

    def origin_in_object(self, link: str) -> list[Lin]:
        """Origin of ``link`` in the object frame (linear in rotations and ``p_palm_in_object``)."""
        if link not in self.origins:
            joint = self.task.hand.joint_of_link(link)
            if joint is None:
                self.origins[link] = [Lin.var(i) for i in self.p_palm_in_object]
            else:
                parent = self.origin_in_object(joint.parent)
                P = self.in_object(joint.parent, joint.origin_in_parent)
                Q = self.in_object(link, joint.origin_in_child)
                self.origins[link] = [parent[r] + P[r] - Q[r] for r in range(3)]
        return self.origins[link]

    # joints ----------------------------------------------------------------------
    def add_joint(self, joint: Joint) -> None:
        b = self.b
        if joint.kind == "revolute":
            v_child = joint.R_parent_child_zero.T @ joint.axis_in_parent
            for e_p, e_c in zip(self.in_object(joint.parent, joint.axis_in_parent), self.in_object(joint.child, v_child)):
                b.equation(e_p - e_c)  # (9)
        else:
            u = self.in_object_vars(joint.parent, joint.axis_in_parent, f"u_{joint.name}")
            v = self.in_object_vars(joint.child, joint.axis_in_child, f"v_{joint.name}")
            b.equation(b.dot(u, v))  # (11)
        for angle in dof_angles(joint):
            self.add_angle(angle)

    def add_angle(self, ang: DofAngle) -> None:
        """``cos theta = a . b`` and ``sin theta = (w x a) . b`` (or ``a . (b x w)``), and the
        limit ``cos(theta - mid) = cos(mid) cos + sin(mid) sin >= cos(half range)``."""
        a = self.in_object_vars(ang.link_a, ang.a, f"a_{ang.dof}")
        bvec = self.in_object_vars(ang.link_b, ang.b, f"b_{ang.dof}")
        cos_i = self.b.as_var_bounded(self.b.dot(a, bvec), f"cos_{ang.dof}", -1.0, 1.0)
        if ang.link_w == ang.link_a:
            perp = self.in_object_vars(ang.link_a, np.cross(ang.w, ang.a), f"aperp_{ang.dof}")
            sin_expr = self.b.dot(perp, bvec)
        else:
            perp = self.in_object_vars(ang.link_b, np.cross(ang.b, ang.w), f"bperp_{ang.dof}")
            sin_expr = self.b.dot(a, perp)
        sin_i = self.b.as_var_bounded(sin_expr, f"sin_{ang.dof}", -1.0, 1.0)
        self.dof_vars[ang.dof] = (cos_i, sin_i)
        self.angles[ang.dof] = ang
        if ang.half_range < np.pi:
            shifted = Lin.var(cos_i, np.cos(ang.mid)) + Lin.var(sin_i, np.sin(ang.mid))
            self.b.inequality(Lin.constant(np.cos(ang.half_range)) - shifted)

    # contacts --------------------------------------------------------------------
    def unit_vector(self, ci: int, side: Side, name: str) -> list[int]:
        nu = [self.base(UnitNormal(ci, side, r), f"{name}[{r}]", -1.0, 1.0) for r in range(3)]
        self.b.equation(lin_sum(Lin.var(self.b.square(i)) for i in nu) - Lin.constant(1.0))
        return nu

    def add_contact(self, ci: int, contact) -> None:
        hreg, oreg = self.task.hand_region(contact), self.task.object_region(contact)
        o, nu, info = form_of(oreg).object_side(self, ci, oreg)
        self.object_points.append(o)
        hand = form_of(hreg.region)
        pos, nh = self.origin_in_object(hreg.link), [n * -1.0 for n in nu]  # hand normal = -object normal
        self.reach_points.append(hand.reach_point(hreg.region, o, nu))
        self.contact_vars.append(hand.hand_side(self, ci, hreg.link, hreg.region, pos, o, nh, info))

    def add_reach_constraints(self) -> None:
        """Redundant distance bounds between the hand balls of the contacts and the palm.

        Every hand region lies in a ball fixed to its link (:func:`reach_ball`); the
        ball's centre is ``o`` for patches and points, and exactly ``o + r nu`` for a
        sphere cap of radius ``r`` (the fingertip centre).  The distance between two
        centres, or from a centre to the palm origin, is at most the hand's span
        (:func:`prehension.hands.reach.span_bound_mm`) plus the balls' radii.  These
        follow from the kinematics and let the relaxations discard at once the boxes in
        which the object's contact regions are farther apart than the hand can reach.
        """
        task, b = self.task, self.b
        points = self.reach_points
        pairs = [(a, None) for a in range(len(points))] + [
            (a, c) for a in range(len(points)) for c in range(a + 1, len(points))
        ]
        for a, c in pairs:
            other = [Lin.var(i) for i in self.p_palm_in_object] if c is None else points[c]
            diff = [b.as_var(points[a][r] - other[r], f"d{a}{'' if c is None else c}[{r}]") for r in range(3)]
            sq = lin_sum(Lin.var(b.square(i)) for i, _ in diff)
            b.inequality(sq - Lin.constant(_ball_reach(task, a, c) ** 2))

    def dot_lin(self, u: list[Lin], v: list[Lin], name: str) -> Lin:
        """``u . v`` for linear expressions (linear when one side is constant)."""
        if all(not e.coeffs for e in u):
            return lin_sum(e * x.const for e, x in zip(v, u))
        if all(not e.coeffs for e in v):
            return lin_sum(e * x.const for e, x in zip(u, v))
        uu = [self.b.as_var(e, f"{name}u[{r}]") for r, e in enumerate(u)]
        vv = [self.b.as_var(e, f"{name}v[{r}]") for r, e in enumerate(v)]
        return self.b.dot(uu, vv)


def reach_ball(task: Task, a: int, *, exact_caps: bool = True) -> tuple[str, np.ndarray, float]:
    """The ball of contact ``a``'s hand region: ``(link, centre in the link frame [mm],
    slack [mm])``.  The slack is the ball's radius, or 0 for a sphere cap when
    ``exact_caps`` (the system knows the cap's centre exactly: ``o + r nu``)."""
    region = task.hand_region(task.contacts[a])
    form = form_of(region.region)
    centre, radius = form.ball(region.region)
    exact = exact_caps and form.exact_centre
    return region.link, centre, 0.0 if exact else radius


def _ball_reach(task: Task, a: int, b: int | None, *, exact_caps: bool = True) -> float:
    link_a, centre_a, slack_a = reach_ball(task, a, exact_caps=exact_caps)
    if b is None:
        return span_bound_mm(task.hand, link_a, centre_a) + slack_a
    link_b, centre_b, slack_b = reach_ball(task, b, exact_caps=exact_caps)
    return span_bound_mm(task.hand, link_a, centre_a, link_b, centre_b) + slack_a + slack_b


def contact_reach(task: Task, a: int, b: int | None = None) -> float:
    """A proven bound on the distance [mm] between the hand points of contacts ``a`` and
    ``b`` (``b=None``: between contact ``a`` and the palm origin), over all configurations
    within the joint limits.

    Each hand region lies in a ball fixed to its link (:meth:`.regions.RegionForm.ball`); the distance
    between the ball centres is bounded by branch and bound over the joint angles
    (:func:`prehension.hands.reach.max_point_distance`: within 1 mm of the true maximum,
    or looser when its box budget runs out; remembered per hand), plus the radii.
    """
    return _ball_reach(task, a, b, exact_caps=False)


def _palm_reach(task: Task) -> float:
    """A bound on the distance from the palm origin to any hand contact point [mm]."""
    return max(contact_reach(task, a) for a in range(len(task.contacts)))


def _object_box(task: Task) -> tuple[np.ndarray, np.ndarray]:
    pts = [form_of(region).box_points(region) for region in map(task.object_region, task.contacts)]
    allp = np.concatenate(pts)
    return allp.min(axis=0), allp.max(axis=0)


def build_system(task: Task, quaternions: str = "none", angles: bool = False) -> Formulation:
    """The canonical system of ``task`` (see the module docstring).

    ``quaternions`` (one of :data:`QUATERNIONS`): which link rotations also get a unit
    quaternion's four variables; ``angles``: whether each joint angle of half range below
    90 deg gets ``sin(theta - mid)``.  Both are added after all other variables (the rest
    of the system, its variables' indices included, is the same as without them)."""
    if quaternions not in QUATERNIONS:
        raise ValueError(f"quaternions must be one of {', '.join(map(repr, QUATERNIONS))}, got {quaternions!r}")
    f = _Formulator(task)
    joints = _loop_joints(task)
    links = [task.hand.palm] + [j.child for j in joints]
    for link in links:
        f.add_link(link)
    lo, hi = _object_box(task)
    reach = _palm_reach(task)
    f.p_palm_in_object = np.array(
        [f.base(PalmOrigin(r), f"p_palm_in_object[{r}]", lo[r] - reach, hi[r] + reach) for r in range(3)]
    )
    for joint in joints:
        f.add_joint(joint)
    for cpl in task.hand.couplings:
        # A coupling with only one side in the system constrains nothing the system sees:
        # dropping it only enlarges the set searched (verification still checks it).
        if cpl.dof in f.dof_vars and cpl.source in f.dof_vars:
            add_coupling(f.b, task.hand, cpl, f.dof_vars)
    for ci, contact in enumerate(task.contacts):
        f.add_contact(ci, contact)
    f.add_reach_constraints()
    for link in {"none": [], "palm": links[:1], "links": links}[quaternions]:
        f.add_quaternion(link)
    for dof in f.dof_vars if angles else ():
        f.add_angle_offset(dof)
    return Formulation(
        task, f.b.build(), tuple(links), f.R_object_link, f.p_palm_in_object, f.dof_vars, tuple(f.contact_vars),
        f.base_keys, f.b, f.quaternion_vars, f.angle_vars,
    )  # fmt: skip
