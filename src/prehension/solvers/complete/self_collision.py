"""A sound self-collision prune: a box all of whose solutions put two links of the hand into each other.

The residual function rejects a configuration in which two capsules of a tested pair
(:func:`prehension.hands.collision.collision_pairs`: links not joined directly and not
excluded) come closer than the sum of their radii by more than ``penetration_mm`` (0 for a
verified solution).  This module proves, for a box of the complete solver, that **every**
solution in it is rejected that way, so the box may be discarded -- as
:mod:`.collision` does for the object.

**Which pairs.**  Only capsules of links *in the system* (:mod:`prehension.system.formulation`:
the links on the paths from the palm to the contact links): their poses are fixed by the
box's rotation variables.  The idle fingers, and the links of a taking-part finger past its
contact link, are moved freely by the verification and the idle settling, so nothing about
them is proved.

**Enclosures of a difference.**  For capsules ``i`` (segment ``a_i``-``b_i``, link ``L_i``)
and ``j``, and any ``s, t`` in ``[0, 1]``, the segment distance is at most
``|p(s) - q(t)|`` with ``p(s) = a_i + s (b_i - a_i)`` and ``q(t)`` likewise.  In the object
frame a point of a system link is linear in the variables
(:func:`.collision._point_rows`), so ``p(s) - q(t)`` is too, and the chains the two links
share cancel exactly in it.  Writing ``p(s) - q(t)`` as the bilinear combination, weights
``(1-s)(1-t), (1-s)t, s(1-t), st`` (summing to 1), of the four end-to-end differences
``x_i - y_j``, its interval hull over the box lies in the box of centre the same
combination of the four hulls' centres and of half-width the same combination of their
half-widths (the triangle inequality on ``|A| half``).  Its largest norm over the box is at
most ``|(max(|lo|, |hi|))|`` of that box.

**Through the contacts.**  At a solution, the anchor ``c`` of a contact (a fingertip cap's
centre, a hand point region's point) is at ``o + rho nu`` of its object region, within the
contact tolerances (:class:`.collision.ContactAnchor`).  When the two links are on
fingers with different contacts ``A`` and ``B``, ``p - q = (p - c_A) - (q - c_B) +
(o_A + rho nu_A) - (o_B + rho nu_B)``: the first part is linear in the rotations between
each link and its anchor's link only, the second is enclosed from the box's object
parameters and normals.  This holds for every *solution* in the box (the prune needs no
more) and is intersected with the chain's box.

**The test.**  The box is pruned when, for some tested pair and some ``(s, t)`` of a grid
(9 x 9 over the square, then 17 x 17 within one step of its best point -- any ``(s, t)`` gives a
valid bound, the grid only looks for a small one),

.. math::

    \\|p(s) - q(t)\\|_{\\max} < r_i + r_j - \\mathrm{penetration\\_mm} - \\mathrm{margin},

``margin`` = :data:`.collision.FLOAT_MARGIN_MM` (the closed-form segment distance of the
residual function is exact up to rounding).  An empty intersection (no solution in the
box) is left to the other proofs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...frozen import cached_per_value
from ...hands.collision import collision_pairs
from ...system.formulation import Formulation
from ...verification.residuals import Tolerances
from .region_kinds import hand_tip
from .collision import FLOAT_MARGIN_MM, ContactAnchor, _affine_hull, _anchor_interval, _compressed, _point_rows

__all__ = ["SelfCollisionPairs", "SelfCollisionProof", "self_collision_pairs", "pair_distance_bounds", "self_collision_prune",
           "GRID", "FINE"]  # fmt: skip

GRID = 9  # points per side of the coarse (s, t) grid
FINE = 17  # points per side of its refinement, one coarse step around the best point


@dataclass(frozen=True, eq=False)
class SelfCollisionPairs:
    """The tested capsule pairs of a formulation whose two links are in the system.

    Attributes:
        links: (K,) the two links of each pair.
        limit: (K,) ``r_i + r_j`` [mm].
        A: (4 * 3K, m) coefficients of the end-to-end differences ``x_i - y_j`` (``xy`` in
            ``aa, ab, ba, bb``; rows ``(e * K + k) * 3 + axis``) in the variables ``columns``.
        columns: (m,) the variables they depend on.
        anchored: per pair, ``(contact A, contact B)`` of the two links' fingers, or ``None``.
        anchor_A: (4 * 3K, m') the same differences through the anchors,
            ``(x_i - c_A) - (y_j - c_B)`` (zero rows for pairs without anchors), in ``anchor_columns``.
        anchor_columns: (m',) their variables.
        anchors: the :class:`.collision.ContactAnchor` of each contact used (``rho`` and the
            contact's object region give ``o + rho nu``).
    """

    links: tuple[tuple[str, str], ...]
    limit: np.ndarray
    A: np.ndarray
    columns: np.ndarray
    anchored: tuple
    anchor_A: np.ndarray
    anchor_columns: np.ndarray
    anchors: dict

    @property
    def size(self) -> int:
        return int(self.limit.size)


@dataclass(frozen=True)
class SelfCollisionProof:
    """Why a box holds no solution: two capsules of ``links`` are closer than ``limit_mm``
    (the sum of their radii) in every solution of the box.

    Attributes:
        links: the two links.
        bound_mm: an upper bound of the distance between the two segments over the box's solutions [mm].
        limit_mm: ``r_i + r_j`` [mm].
    """

    links: tuple[str, str]
    bound_mm: float
    limit_mm: float


# -- building the pairs -----------------------------------------------------------------
@cached_per_value
def self_collision_pairs(form: Formulation) -> SelfCollisionPairs | None:
    """The capsule pairs of a formulation to test (kept per formulation), or ``None`` when
    no tested pair has both links in the system."""
    hand, n = form.task.hand, form.system.n
    pairs = collision_pairs(hand)
    names = hand.link_names
    anchor_of = _anchor_contacts(form)
    rows, anchor_rows, links, limit, anchored = [], [], [], [], []
    for k, (li, lj) in enumerate(pairs.names):
        if li not in form.R_object_link or lj not in form.R_object_link:
            continue
        i, j = pairs.first[k], pairs.second[k]
        assert names[pairs.link[i]] == li and names[pairs.link[j]] == lj
        ends_i = [_point_rows(form, li, e, n) for e in (pairs.a[i], pairs.b[i])]
        ends_j = [_point_rows(form, lj, e, n) for e in (pairs.a[j], pairs.b[j])]
        rows.append([x - y for x in ends_i for y in ends_j])  # aa, ab, ba, bb
        A, B = anchor_of.get(li), anchor_of.get(lj)
        if A is not None and B is not None and A[0] != B[0]:
            ca, cb = A[1], B[1]
            anchor_rows.append([(x - ca) - (y - cb) for x in ends_i for y in ends_j])
            anchored.append((A[0], B[0]))
        else:
            anchor_rows.append([np.zeros((3, n))] * 4)
            anchored.append(None)
        links.append((li, lj))
        limit.append(float(pairs.radius[i] + pairs.radius[j]))
    if not links:
        return None
    # (K, 4, 3, n) -> rows (e * K + k) * 3 + axis
    stacked = np.stack([np.stack(r) for r in rows]).transpose(1, 0, 2, 3).reshape(-1, n)
    anchor_stacked = np.stack([np.stack(r) for r in anchor_rows]).transpose(1, 0, 2, 3).reshape(-1, n)
    A, columns = _compressed(stacked)
    anchor_A, anchor_columns = _compressed(anchor_stacked)
    used = {c for pair in anchored if pair is not None for c in pair}
    anchors = {c: _contact_anchor(form, c) for c in used}
    return SelfCollisionPairs(tuple(links), np.array(limit), A, columns, tuple(anchored), anchor_A, anchor_columns, anchors)


def _anchor_contacts(form: Formulation) -> dict[str, tuple[int, np.ndarray]]:
    """Per system link on a finger with a fingertip-cap or point contact: ``(contact, rows
    of its anchor c (3, n))``, the first such contact of the finger; the palm's links (on no
    finger) take a palm contact's, if any."""
    task, n = form.task, form.system.n
    finger_of = {link: f.name for f in task.hand.fingers for link in f.links}
    out: dict[str, tuple[int, np.ndarray]] = {}
    by_group: dict = {}
    for ci, contact in enumerate(task.contacts):
        hreg = task.hand_region(contact)
        tip = hand_tip(hreg.region)
        if tip is None:
            continue  # a hand patch: its point is a product of variables
        by_group.setdefault(finger_of.get(hreg.link), (ci, _point_rows(form, hreg.link, tip.centre, n)))
    for link in form.R_object_link:
        group = finger_of.get(link)
        if group in by_group:
            out[link] = by_group[group]
    return out


def _contact_anchor(form: Formulation, ci: int) -> ContactAnchor:
    """The :class:`.collision.ContactAnchor` of contact ``ci`` (its ``rho``; no rows needed)."""
    tip = hand_tip(form.task.hand_region(form.task.contacts[ci]).region)
    rho = tip.radius if tip is not None else 0.0
    return ContactAnchor(ci, rho, np.zeros((0, 0)), np.zeros(0, dtype=np.int64))


# -- the test ---------------------------------------------------------------------------
def _end_boxes(pairs: SelfCollisionPairs, form: Formulation, lower, upper, tolerances: Tolerances | None):
    """Centres and half-widths (4, K, 3) of the end-to-end differences over the box: the
    chain's, and (with ``tolerances``) ``(centre, half, usable (K,))`` through the anchors
    (``None`` without any)."""
    K = pairs.size
    lo, hi = _affine_hull(pairs.A, pairs.columns, 0.0, lower, upper)
    boxes = [(0.5 * (lo + hi)).reshape(4, K, 3), (0.5 * (hi - lo)).reshape(4, K, 3)]
    if tolerances is None or not pairs.anchors:
        return boxes, None
    intervals = {c: _anchor_interval(form, a, lower, upper, tolerances) for c, a in pairs.anchors.items()}
    lo, hi = _affine_hull(pairs.anchor_A, pairs.anchor_columns, 0.0, lower, upper)
    centre, half = (0.5 * (lo + hi)).reshape(4, K, 3), (0.5 * (hi - lo)).reshape(4, K, 3)
    usable = np.zeros(K, dtype=bool)
    for k, pair in enumerate(pairs.anchored):
        if pair is None:
            continue
        (a_lo, a_hi), (b_lo, b_hi) = intervals[pair[0]], intervals[pair[1]]
        if a_lo is None or b_lo is None:
            continue
        d_lo, d_hi = a_lo - b_hi, a_hi - b_lo  # o_A + rho nu_A - (o_B + rho nu_B)
        centre[:, k] += 0.5 * (d_lo + d_hi)
        half[:, k] += 0.5 * (d_hi - d_lo)
        usable[k] = True
    return boxes, (centre, half, usable)


def _weights(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(..., 4) bilinear weights (1-s)(1-t), (1-s)t, s(1-t), st of the ends aa, ab, ba, bb."""
    return np.stack([(1 - s) * (1 - t), (1 - s) * t, s * (1 - t), s * t], axis=-1)


def _bounds_from(values: np.ndarray, anchored: np.ndarray | None) -> np.ndarray:
    """Upper bounds of ``|p(s) - q(t)|`` (...,) from the interpolated ``values`` (..., 6 or
    12): the chain's centre and half-width, then the anchors' (``anchored``, broadcast
    against ``values[..., :3]``, says where they are usable); ``inf`` where the two enclosures do not meet (no solution there, left
    to the other proofs)."""
    lo, hi = values[..., 0:3] - values[..., 3:6], values[..., 0:3] + values[..., 3:6]
    if anchored is not None:
        a_lo, a_hi = values[..., 6:9] - values[..., 9:12], values[..., 6:9] + values[..., 9:12]
        lo, hi = np.where(anchored, np.maximum(lo, a_lo), lo), np.where(anchored, np.minimum(hi, a_hi), hi)
    bound = np.sqrt(np.sum(np.maximum(np.abs(lo), np.abs(hi)) ** 2, axis=-1))
    return np.where(np.all(lo <= hi, axis=-1), bound, np.inf)


def pair_distance_bounds(form: Formulation, lower, upper, tolerances: Tolerances | None = None) -> np.ndarray | None:
    """(K,) upper bounds [mm] of the distance between the two segments of each pair of
    :func:`self_collision_pairs` over the box ``[lower, upper]``: for every configuration of
    the box, or (with ``tolerances``) for every one whose contacts are made within them --
    every solution.  ``None`` without pairs.

    The bilinear interpolation of the ends' boxes is a product with a (G, 4) matrix of
    weights on the coarse grid; the refinement (pairs whose coarse bound is below twice
    their limit only: the others are far from colliding) has its own grid per pair.
    """
    pairs = self_collision_pairs(form)
    if pairs is None:
        return None
    chain, through = _end_boxes(pairs, form, np.asarray(lower, dtype=float), np.asarray(upper, dtype=float), tolerances)
    parts = list(chain) if through is None else list(chain) + [through[0], through[1]]
    V = np.concatenate(parts, axis=-1).transpose(1, 0, 2)  # (K, 4, 6 or 12)
    anchored = None if through is None else through[2][:, None, None]
    K = pairs.size
    grid = np.linspace(0.0, 1.0, GRID)
    s, t = (g.ravel() for g in np.meshgrid(grid, grid, indexing="ij"))
    # batched products (K small matrices): a plain (G, 4) @ (4, 12 K) product goes through a
    # multithreaded BLAS, 20x slower on a loaded machine
    coarse = _bounds_from(np.matmul(_weights(s, t)[None], V), anchored)  # (K, G)
    best = np.argmin(coarse, axis=1)
    out = coarse[np.arange(K), best]
    near = np.flatnonzero(out < 2.0 * pairs.limit)
    if near.size:
        step = 1.0 / (GRID - 1)
        offsets = np.linspace(-step, step, FINE)
        fs, ft = (g.ravel() for g in np.meshgrid(offsets, offsets, indexing="ij"))
        s2 = np.clip(s[best[near]][:, None] + fs[None], 0.0, 1.0)  # (k, G)
        t2 = np.clip(t[best[near]][:, None] + ft[None], 0.0, 1.0)
        fine = _bounds_from(np.matmul(_weights(s2, t2), V[near]), None if anchored is None else anchored[near])
        out[near] = np.minimum(out[near], fine.min(axis=1))
    return out


def self_collision_prune(form: Formulation, lower, upper, tolerances: Tolerances) -> SelfCollisionProof | None:
    """A proof that every configuration in the box whose contacts are made within
    ``tolerances`` has two capsules of system links deeper into each other than
    ``tolerances.penetration_mm`` (see the module docstring), or ``None``."""
    tol_mm = tolerances.penetration_mm
    if not np.isfinite(tol_mm):
        return None
    bounds = pair_distance_bounds(form, lower, upper, tolerances)
    if bounds is None:
        return None
    pairs = self_collision_pairs(form)
    slack = pairs.limit - tol_mm - FLOAT_MARGIN_MM - bounds
    k = int(np.argmax(slack))
    if not slack[k] > 0.0:
        return None
    return SelfCollisionProof(pairs.links[k], float(bounds[k]), float(pairs.limit[k]))
