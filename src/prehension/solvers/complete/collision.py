"""A sound collision prune: a box all of whose configurations put a link into the object.

The residual function rejects a configuration in which some link reaches deeper than
``object_penetration_mm`` into the object's solid (only a capsule ball inside its own
contact's pad excused), or some pad does (:mod:`prehension.tasks.object_collision`).  This module proves, for a box of the
complete solver, that **every** configuration in it is rejected that way, so the box holds
no solution and may be discarded.

**Probe points.**  Each capsule of each link (segment ``a``-``b``, radius ``r``) is sampled
at fixed points ``p`` of its segment (link frame, at most :data:`PROBE_SPACING_MM` apart).
A capsule's depth is ``max(0, r - min sd)`` over its segment, with ``sd`` the object's
signed distance (1-Lipschitz, negative inside), so ``sd(p) < r - tol`` at any one point
``p`` of a checked segment means the link is deeper than ``tol``.

**Enclosures.**  The system is written in the object frame (:mod:`prehension.system.formulation`):
a link of the system has its rotation ``R_object_link`` among the variables and its origin
``r_0 + sum (R_parent P - R_child Q)`` linear in them, so a probe point
``origin + R_object_link p`` is a linear expression ``c + A x`` of the variables, and its
interval over the box ``[lower, upper]`` is ``c + A mid +- |A| half`` (``mid``, ``half``
the box's centre and half-widths; rounded outwards by a relative 1e-9): an axis-aligned
box ``B`` that holds the point for every configuration of the box.

**Through the contacts.**  The chain from the palm adds up the widths of every rotation
on the way, so far from the palm it is loose.  At a solution each contact is made: a
fingertip cap's centre ``c`` (or a hand point region's point) is at ``o + rho nu`` (the
object point pushed out along its normal by the cap radius), within the contact
tolerances.  So a probe point is also ``o + rho nu + (x_probe - x_c)``: ``o + rho nu`` is
enclosed from the box's object parameters and normals (a patch's sub-patch control
points), and the difference is linear in the rotations of the links between the two (the
palm origin cancels).  Every such enclosure holds every *solution* in the box (not every
configuration: only those whose contacts are made, which is all the prune needs); their
intersection with the chain's is used (:class:`ContactAnchor`).

**Links the search does not model.**  Idle fingers, and the links of a taking-part finger
beyond its contact link, are not in the system (the local refinement and the idle settling
of :func:`prehension.results.make_solution` move them freely within their limits).  Such a
link hangs from a system link ``A`` through a chain of joints; whatever the angles, a point
``p`` of it lies within ``e`` of the first joint's centre ``J`` (a point fixed in ``A``),
where ``e`` sums the distances between consecutive joint centres along the chain and
``|p - Q|`` on the last link (``Q`` its joint centre).  The probe is then ``J``
(enclosed as above) with the extra radius ``e``.

**The test.**  With ``B`` the enclosure of ``J`` (or of ``p``, ``e = 0``), every point of
the ball of radius ``e`` around ``B`` satisfies ``sd <= sd(centre(B)) + halfdiag(B) + e``.
The box is pruned when, for some probe,

.. math::

    \\mathrm{sd}(\\mathrm{centre}(B)) + \\mathrm{halfdiag}(B) + e < r - \\mathrm{tol} - \\mathrm{margin},

``margin`` = :data:`SAMPLE_MM` / 2 (the residual function finds the depth of a segment that
reaches inside by Lipschitz bisection to within 0.125 mm, as samples 0.25 mm apart would,
so it may read up to 0.125 mm low) + :data:`FLOAT_MARGIN_MM`
(the distance structure is exact up to rounding).

**The pads.**  The residual function excuses, on a contact's link, only the capsule balls
inside the contact's pad ball (a fingertip cap's ball ``B(c, rho)``, fixed on the link:
``|p - c| <= rho - r``; a point or patch hand region excuses nothing), and checks the pad
itself: ``rho - sd(c)`` at most the tolerance.  Both are fixed on the link, so a probe
with ``|p - c| > rho - r`` (+ a small margin) is never excused, whatever the
configuration, and each pad is a probe of its own (its centre ``c`` with radius ``rho``;
a hand point region's point with radius 0; a hand patch's point moves over the patch and
gives none).  The residual function's pad depth is one exact query, so the same test
with the same margin is sound for it.
No probe is used on any doubt: an object without a solid, or with
``collisions: false``, is never pruned this way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...frozen import cached_per_value
from ...system.formulation import Formulation
from ...tasks.object_collision import SAMPLE_MM, pad_centre_in_link, pad_radius
from ...verification.residuals import Tolerances
from .region_kinds import hand_tip, offset_point_box

__all__ = ["CollisionProbes", "CollisionProof", "ContactAnchor", "collision_probes", "probe_enclosures", "collision_prune",
           "PROBE_SPACING_MM", "FLOAT_MARGIN_MM"]  # fmt: skip

PROBE_SPACING_MM = 5.0  # largest distance between two probe points of a capsule [mm]
FLOAT_MARGIN_MM = 1e-6  # rounding of the distance structure and of the enclosures [mm]
_PAD_MARGIN_MM = 1e-3  # a probe's ball this much farther from inside a pad than the residual function excuses [mm]
_ROUNDING = 1e-9  # outward rounding of an enclosure, relative to its magnitude


@dataclass(frozen=True, eq=False)
class CollisionProbes:
    """Probe points of a task's system (see the module docstring).

    Attributes:
        A: (3K, m) coefficients of the K probe points' object-frame coordinates in the
            system variables ``columns`` (rows ``3k, 3k+1, 3k+2`` for probe ``k``) [mm].
        columns: (m,) the variables the probes depend on (rotation entries, palm origin).
        const: (3K,) constant terms [mm].
        radius: (K,) radius ``r`` of the capsule each probe lies on [mm].
        extra: (K,) extra radius ``e``: 0 for a link of the system, else the reach of the
            probe's point from its joint centre ``J`` [mm].
        link: (K,) name of the link each probe belongs to.
        point_in_link: (K, 3) the probe's point ``p`` in its link's frame [mm].
        deepest_mm: a bound on ``-sd`` over the whole space: half the smallest side of the
            surface's bounding box (no point of the solid is farther from the surface) [mm].
        anchors: second enclosures of the same points, through each contact's anchor
            (see :class:`ContactAnchor`), intersected with the first.
    """

    A: np.ndarray
    columns: np.ndarray
    const: np.ndarray
    radius: np.ndarray
    extra: np.ndarray
    link: tuple[str, ...]
    point_in_link: np.ndarray
    deepest_mm: float
    anchors: tuple = ()

    @property
    def size(self) -> int:
        return int(self.radius.size)


@dataclass(frozen=True, eq=False)
class ContactAnchor:
    """The probes through contact ``contact``: at a solution, the hand region's anchor ``c``
    (a fingertip cap's centre, or a hand point region's point; link frame of ``link``) is
    at ``o + rho nu`` in the object frame (``o`` the object point, ``nu`` its unit outward
    normal, ``rho`` the cap radius or 0), within the contact tolerances.  So a probe point
    is ``o + rho nu + (x_probe - x_c)``, the difference linear in the rotations only
    (the palm origin cancels): ``A`` (3K, m) in the variables ``columns``.  Near the
    contact this is far tighter than the chain from the palm.
    """

    contact: int
    rho: float
    A: np.ndarray
    columns: np.ndarray


@dataclass(frozen=True)
class CollisionProof:
    """Why a box holds no solution: a probe on ``link`` is deeper than the tolerance in every
    configuration of the box.

    Attributes:
        link: the link proven to penetrate.
        bound_mm: an upper bound of ``sd`` at the probe over the box [mm] (``sd(centre) +
            halfdiag + e``), below ``radius - tol - margin``.
        radius: the capsule's radius [mm].
    """

    link: str
    bound_mm: float
    radius: float


# -- building the probes ----------------------------------------------------------------
@cached_per_value
def collision_probes(form: Formulation) -> CollisionProbes | None:
    """The probes of a formulation (kept per formulation); ``None`` when the task's object
    does not collide (no solid, or ``collisions: false``) or no probe can be used."""
    return _build_probes(form) if form.task.object.collides else None


def _build_probes(form: Formulation) -> CollisionProbes | None:
    hand, n = form.task.hand, form.system.n
    pads = _pads_by_link(form)
    rows, radius, extra, names, points = [], [], [], [], []
    for link in hand.links:
        shapes = [(p, float(cap.radius)) for cap in link.collision for p in _segment_points(cap.a, cap.b)
                  if _outside_pads(p, float(cap.radius), pads.get(link.name, ()))]  # fmt: skip
        shapes += [(c, rho) for c, rho in pads.get(link.name, ())]  # the pads themselves
        if not shapes:
            continue
        anchor, J, reach = _anchor(form, link.name)
        for p, r in shapes:
            if J is None:  # a link of the system: the point itself
                point, e = p, 0.0
            else:  # outside it: the joint centre J, and how far p can be from it
                point, e = J, reach + float(np.linalg.norm(p - _last_centre(form, link.name)))
            rows.append(_point_rows(form, anchor, point, n))
            radius.append(r), extra.append(e), names.append(link.name), points.append(p)
    if not rows:
        return None
    A, columns = _compressed(np.vstack(rows))
    deepest = 0.5 * float(np.ptp(form.task.object.surface.vertices, axis=0).min())
    anchors = tuple(_contact_anchors(form, np.vstack(rows)))
    return CollisionProbes(A, columns, np.zeros(A.shape[0]), np.array(radius), np.array(extra), tuple(names), np.array(points),
                           deepest, anchors)  # fmt: skip


def _compressed(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(A[:, columns], columns)``: only the columns with a nonzero coefficient."""
    columns = np.flatnonzero(np.any(A != 0.0, axis=0))
    return np.ascontiguousarray(A[:, columns]), columns


def _contact_anchors(form: Formulation, rows: np.ndarray) -> list[ContactAnchor]:
    """One :class:`ContactAnchor` per contact whose hand region is a cap or a point."""
    out = []
    for ci, contact in enumerate(form.task.contacts):
        hreg = form.task.hand_region(contact)
        tip = hand_tip(hreg.region)
        if tip is None:
            continue  # a hand patch: its point is a product of variables
        anchor_rows = _point_rows(form, hreg.link, tip.centre, form.system.n)
        A, columns = _compressed(rows - np.tile(anchor_rows, (rows.shape[0] // 3, 1)))
        out.append(ContactAnchor(ci, tip.radius, A, columns))
    return out


def _segment_points(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(m, 3) points of segment a-b, ends included, at most PROBE_SPACING_MM apart [mm]."""
    m = int(np.ceil(np.linalg.norm(b - a) / PROBE_SPACING_MM)) + 1
    return a + np.linspace(0.0, 1.0, max(m, 1))[:, None] * (b - a)


def _pads_by_link(form: Formulation) -> dict[str, list[tuple[np.ndarray, float]]]:
    """Per link: ``(centre [mm], rho [mm])`` in the link's frame of each contact's pad that
    is fixed on it: a sphere cap's ball, a point region's point (``rho = 0``); a patch's
    pad (its moving hand point) is left out, and excuses nothing either."""
    task, out = form.task, {}
    for contact in task.contacts:
        hreg = task.hand_region(contact)
        centre, tip = pad_centre_in_link(hreg), hand_tip(hreg.region)
        if centre is None and tip is not None and not tip.cone:  # a point region's point
            centre = tip.centre
        if centre is not None:
            out.setdefault(hreg.link, []).append((centre, pad_radius(hreg)))
    return out


def _outside_pads(p: np.ndarray, r: float, pads) -> bool:
    """Whether the ball ``B(p, r)`` lies inside no pad ``B(c, rho)`` (by a margin): the
    residual function never excuses it."""
    return all(np.linalg.norm(p - c) > rho - r + _PAD_MARGIN_MM for c, rho in pads)


def _anchor(form: Formulation, link: str) -> tuple[str, np.ndarray | None, float]:
    """``(system link A, joint centre J in A or None, reach)`` of a link: the link itself
    (``J = None``) when it is in the system, else its nearest system ancestor, the centre
    of the first joint below it, and the sum of the joint-centre distances from that
    joint to the link's own joint [mm]."""
    hand, chain = form.task.hand, []
    while link not in form.R_object_link:
        joint = hand.joint_of_link(link)
        chain.append(joint)
        link = joint.parent
    if not chain:
        return link, None, 0.0
    chain.reverse()  # from the system link outwards
    reach = sum(float(np.linalg.norm(nxt.origin_in_parent - cur.origin_in_child)) for cur, nxt in zip(chain, chain[1:]))
    return link, np.asarray(chain[0].origin_in_parent, dtype=float), reach


def _last_centre(form: Formulation, link: str) -> np.ndarray:
    """The centre of the joint that carries ``link``, in the link's frame [mm]."""
    return np.asarray(form.task.hand.joint_of_link(link).origin_in_child, dtype=float)


def _point_rows(form: Formulation, link: str, p: np.ndarray, n: int) -> np.ndarray:
    """(3, n) coefficients of ``origin(link) + R_object_link p`` (object frame) [mm]."""
    rows = _origin_rows(form, link, n)
    R = form.R_object_link[link]
    for r in range(3):
        for c in range(3):
            rows[r, R[r, c]] += p[c]
    return rows


def _origin_rows(form: Formulation, link: str, n: int) -> np.ndarray:
    """(3, n) coefficients of a system link's origin: ``r_0 + sum (R_parent P - R_child Q)``."""
    joint = form.task.hand.joint_of_link(link)
    if joint is None:
        rows = np.zeros((3, n))
        rows[np.arange(3), form.p_palm_in_object] = 1.0
        return rows
    rows = _point_rows(form, joint.parent, np.asarray(joint.origin_in_parent, dtype=float), n)
    R = form.R_object_link[link]
    for r in range(3):
        for c in range(3):
            rows[r, R[r, c]] -= joint.origin_in_child[c]
    return rows


# -- the test ---------------------------------------------------------------------------
def probe_enclosures(
    probes: CollisionProbes, lower: np.ndarray, upper: np.ndarray, form: Formulation | None = None,
    tolerances: Tolerances | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``(lo, hi)``, each (K, 3) [mm]: a box holding each probe's point (its joint centre
    ``J`` for links outside the system) for every point of the box ``[lower, upper]``.

    With ``form`` and ``tolerances``, intersected with the enclosures through each contact
    anchor (:class:`ContactAnchor`), which hold for every configuration of the box whose
    contacts are made within ``tolerances`` -- every solution; then ``lo > hi`` somewhere
    means no solution lies in the box.
    """
    lo, hi = _affine_hull(probes.A, probes.columns, probes.const, lower, upper)
    if form is not None and tolerances is not None:
        for anchor in probes.anchors:
            a_lo, a_hi = _anchor_interval(form, anchor, lower, upper, tolerances)
            if a_lo is None:
                continue
            d_lo, d_hi = _affine_hull(anchor.A, anchor.columns, 0.0, lower, upper)
            k = d_lo.size // 3
            lo, hi = np.maximum(lo, d_lo + np.tile(a_lo, k)), np.minimum(hi, d_hi + np.tile(a_hi, k))
    return lo.reshape(-1, 3), hi.reshape(-1, 3)


def _affine_hull(A, columns, const, lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Interval hull ``(lo, hi)`` (R,) of ``const + A x`` over the box (outward rounded)."""
    lower, upper = lower[columns], upper[columns]
    mid, half = 0.5 * (lower + upper), 0.5 * (upper - lower)
    centre = const + A @ mid
    radius = np.abs(A) @ half  # the interval c + A [lower, upper] is centre +- radius
    size = np.abs(const) + np.abs(A) @ np.maximum(np.abs(lower), np.abs(upper))
    pad = radius + _ROUNDING * (1.0 + size)
    return centre - pad, centre + pad


def _anchor_interval(form: Formulation, anchor: ContactAnchor, lower, upper, tol: Tolerances):
    """``(lo, hi)`` (3,) [mm] holding ``o + rho nu`` of the anchor's contact over the box,
    grown by what the contact tolerances allow (``(None, None)`` when they are not finite)."""
    slack = tol.contact_mm + anchor.rho * np.radians(tol.normal_deg)
    if not np.isfinite(slack):
        return None, None
    region = form.task.object_region(form.task.contacts[anchor.contact])
    lo, hi = offset_point_box(region, form.contact_vars[anchor.contact], lower, upper, anchor.rho)
    pad = slack + _ROUNDING * (1.0 + np.abs(lo) + np.abs(hi))
    return lo - pad, hi + pad


def collision_prune(form: Formulation, lower: np.ndarray, upper: np.ndarray, tolerances: Tolerances) -> CollisionProof | None:
    """A proof that every configuration in the box whose contacts are made within
    ``tolerances`` puts some link deeper than ``tolerances.object_penetration_mm`` into
    the object or sinks some pad deeper (see the module docstring), or ``None``."""
    probes, tol_mm = collision_probes(form), tolerances.object_penetration_mm
    if probes is None or not np.isfinite(tol_mm):
        return None
    lo, hi = probe_enclosures(probes, lower, upper, form, tolerances)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo <= hi)):
        return None  # (an empty intersection: no solution in the box either; left to the other proofs)
    # sd(centre) + halfdiag + e < r - tol - margin is the proof; sd >= -deepest anywhere,
    # so only the probes whose other terms leave room for it cost a distance query.
    reach = 0.5 * np.linalg.norm(hi - lo, axis=1) + probes.extra
    need = probes.radius - tol_mm - (0.5 * SAMPLE_MM + FLOAT_MARGIN_MM) - reach
    hopeful = np.flatnonzero(need > -probes.deepest_mm)
    if hopeful.size == 0:
        return None
    sd = form.task.object.distance.signed_distance(0.5 * (lo[hopeful] + hi[hopeful]))
    k = int(np.argmax(need[hopeful] - sd))
    if need[hopeful[k]] - sd[k] <= 0.0:
        return None
    i = hopeful[k]
    return CollisionProof(probes.link[i], float(sd[k] + reach[i]), float(probes.radius[i]))
