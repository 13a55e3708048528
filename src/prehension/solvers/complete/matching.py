r"""The pair test by matching ranges: each side's pose-free invariants bounded on its own boxes.

The pair test of :mod:`.congruence` searches the *product* of the pair's joint angles and
its object regions' parameters.  Its conditions, though, compare a quantity of the hand
side (a function of the angles alone) with one of the object side (of the parameters
alone): the distance ``D = |c_b - c_a|`` between the fingertip centres (hand points),
per side ``i`` the angle ``theta_i`` between ``d = c_b - c_a`` and the cap's axis ``m_i``
(object side: ``phi_i`` between ``d`` and the contact normal ``h_i``), the angle between
the two axes (normals) and the dihedral angle of the planes ``(d, m_a), (d, m_b)``
(``(d, h_a), (d, h_b)``).  A grasp makes a rotation carry the hand side onto the object
side with each normal within ``beta_i`` (the cap's half angle; 0 for a hand point) of its
axis, so, on the sphere (triangle inequality):

.. math::

    D^{hand} = D^{obj}, \qquad |\theta_i - \phi_i| \le \beta_i, \qquad
    |\angle(m_a, m_b) - \angle(h_a, h_b)| \le \beta_a + \beta_b,

and the twist about ``d`` must meet both cones at once (the arcs of
:func:`.congruence.twist_possible`).  Bounding each side's invariants over its own boxes
and keeping the pairs of boxes whose ranges allow these relations (:func:`compatible`)
discards exactly what the product test's separate checks discard on the product of the
two boxes, but the subdivisions add up instead of multiplying: the hand side is split
over its angles only and the object side over its parameters only.

:func:`prove_pair_by_matching` alternates: match, drop the boxes of either side that no box
of the other side matches, narrow the survivors of one side to the hull of the other side's
ranges (:func:`contract_to`), split them (the side with fewer boxes, through the dimension
that moves its invariants most).  No hand box left: the pair,
hence the task, cannot be made (for any number of contacts).  Rounding: every range is
widened outwards (relative 1e-9 on lengths and cosines, 1e-7 rad on the angle tests).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...geometry.regions import SphereCap
from . import affine as af
from .congruence import (PairOutcome, PairProblem, _axial, _dihedral, _half_width_upper, _halves, _hand_forms,
                         _interval, _length, _object_forms, _vector_spread)  # fmt: skip

__all__ = ["MAX_PAIRS", "SideRanges", "Hull", "hand_ranges", "object_ranges", "compatible", "hull_of", "contract_to",
           "prove_pair_by_matching"]

_REL_PAD = 1e-9
_ANGLE_PAD = 1e-7  # [rad]

#: The search stops (without a proof) before a round that would match more pairs of boxes:
#: where both sides keep many boxes (a pair that can be made) matching costs their product;
#: the lid's proofs at t* + 0.5 .. 2 mm never match more than ~1.3 M.
MAX_PAIRS = 4_000_000


@dataclass(frozen=True)
class SideRanges:
    """Bounds of one side's invariants over ``B`` boxes (every array ``(B,)``).

    ``distance``: ``|d|`` [mm]; ``angle``: per side ``i`` the angle [rad] between ``d`` and the
    axis (normal) of side ``i``; ``axial``: per side ``i`` bounds of ``cos`` of that angle
    (the twist's half widths need them); ``between``: the angle between the two axes
    (normals) [rad]; ``dihedral``: the signed dihedral angle [rad] about ``d`` from the plane
    of side a to that of side b, and whether it is known (not where it is undefined).
    """

    distance: tuple[np.ndarray, np.ndarray]
    axial: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    angle: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    between: tuple[np.ndarray, np.ndarray]
    dihedral: tuple[np.ndarray, np.ndarray, np.ndarray]

    def rows(self, keep: np.ndarray) -> SideRanges:
        pick = lambda t: tuple(x[keep] for x in t)  # noqa: E731
        return SideRanges(pick(self.distance), (pick(self.axial[0]), pick(self.axial[1])),
                          (pick(self.angle[0]), pick(self.angle[1])), pick(self.between), pick(self.dihedral))  # fmt: skip


def _cos_interval(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A cosine interval widened outwards for rounding, clipped to ``[-1, 1]``."""
    return np.clip(lo - (_REL_PAD * np.abs(lo) + _REL_PAD), -1.0, 1.0), np.clip(hi + (_REL_PAD * np.abs(hi) + _REL_PAD), -1.0, 1.0)


def _angles(cos: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return np.arccos(cos[1]), np.arccos(cos[0])


def _ranges(d: af.Form, v_a: af.Form, v_b: af.Form) -> SideRanges:
    """Invariant ranges of ``d`` and the two unit vectors ``v_a, v_b`` (forms over the boxes)."""
    length = _length(d)
    squared = _interval(af.dot(d, d))  # the term-by-term quadratic: often tighter than |c| -+ spread
    n = d.c / np.maximum(np.linalg.norm(d.c, axis=1), 1e-300)[:, None]
    projected = np.linalg.norm(d.c, axis=1) - np.abs(np.einsum("bi,bik->bk", n, d.A)).sum(axis=1) - d.rho
    lower = np.maximum.reduce([length[0], projected, np.sqrt(np.maximum(squared[0], 0.0))])
    upper = np.minimum(length[1], np.sqrt(np.maximum(squared[1], 0.0)))
    distance = (np.maximum(lower * (1.0 - _REL_PAD) - _REL_PAD, 0.0), upper * (1.0 + _REL_PAD) + _REL_PAD)
    axial = tuple(_cos_interval(*_axial(d, v, length)) for v in (v_a, v_b))
    between = _angles(_cos_interval(*_interval(af.dot(v_a, v_b))))
    return SideRanges(distance, axial, tuple(_angles(a) for a in axial), between, _dihedral(d, v_a, v_b, length))


def _full(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, dims: slice) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of the pair's full dimensions: ``lo, hi (B, k)`` on ``dims``, the others a point."""
    full_lo = np.repeat(pp.lower[None], len(lo), axis=0)
    full_lo[:, dims] = lo
    full_hi = full_lo.copy()
    full_hi[:, dims] = hi
    return full_lo, full_hi


def hand_ranges(pp: PairProblem, lo: np.ndarray, hi: np.ndarray) -> tuple[SideRanges, np.ndarray]:
    """The hand side's ranges over boxes of the pair's angles ``(B, n)`` and each angle's
    split score ``(B, n)`` (how far it moves ``d / |d|`` and the two axes, with the remainder
    shared by squared relative width)."""
    full_lo, full_hi = _full(pp, lo, hi, pp.slices[0])
    zc, half = 0.5 * (full_lo + full_hi), 0.5 * (full_hi - full_lo)
    d, (m_a, m_b) = _hand_forms(pp, zc, half)
    ranges = _ranges(d, m_a, m_b)
    upper, _ = pp.kin.distance_upper_mm(lo, hi)  # the span search's bound: quadratic near the maximum
    ranges = SideRanges((ranges.distance[0], np.minimum(ranges.distance[1], upper * (1.0 + _REL_PAD) + _REL_PAD)),
                        ranges.axial, ranges.angle, ranges.between, ranges.dihedral)  # fmt: skip
    return ranges, _scores(pp, (d, m_a, m_b), full_lo, full_hi, pp.slices[0])


def object_ranges(pp: PairProblem, lo: np.ndarray, hi: np.ndarray) -> tuple[SideRanges, np.ndarray]:
    """The object side's ranges over boxes of the two regions' parameters ``(B, p)`` (``d``
    between the fingertip centres ``o + r nu`` when touching, ``h = -nu``) and split scores."""
    dims = slice(pp.slices[1].start, pp.n_dims)
    full_lo, full_hi = _full(pp, lo, hi, dims)
    zc, half = 0.5 * (full_lo + full_hi), 0.5 * (full_hi - full_lo)
    d, h_a, h_b = _object_forms(pp, zc, half)
    return _ranges(d, h_a, h_b), _scores(pp, (d, h_a, h_b), full_lo, full_hi, dims)


@dataclass(frozen=True)
class Hull:
    """What a box of one side must reach for some box of the other side to match it: the
    distance ``|d|`` [mm] in ``distance`` and, per side ``i``, the angle between ``d`` and
    the axis (normal) of side ``i`` [rad] in ``angle[i]`` (the other side's angle widened by
    the cap's half angle ``beta_i``)."""

    distance: tuple[float, float]
    angle: tuple[tuple[float, float], tuple[float, float]]


def hull_of(ranges: SideRanges, betas: tuple[float, float]) -> Hull:
    """The hull of one side's ranges over all its boxes, as a target for the other side
    (``ranges`` must hold at least one box)."""
    angle = tuple((max(float(ranges.angle[s][0].min()) - betas[s] - _ANGLE_PAD, 0.0),
                   min(float(ranges.angle[s][1].max()) + betas[s] + _ANGLE_PAD, np.pi)) for s in (0, 1))  # fmt: skip
    return Hull((float(ranges.distance[0].min()), float(ranges.distance[1].max())), angle)


def contract_to(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, hull: Hull, *, hand: bool) -> tuple[np.ndarray, np.ndarray]:
    """Narrow boxes ``(B, k)`` of one side (the hand's angles when ``hand``, else the object
    regions' parameters) to the points whose ``|d|^2`` lies in ``hull.distance`` squared and
    whose ``v_i . d`` lies in ``|d| cos(hull.angle[i])`` (both bounds of ``|d|`` taken), by
    the linear contraction of the affine forms (:func:`.affine.contract_equal`, twice).
    Returns the narrowed boxes; an empty one has some ``lo > hi``.

    Sound: a grasp's point of this side lies, at every round of
    :func:`prove_pair_by_matching`, in a box matched by a box of the other side holding the
    grasp's other point, whose invariants equal this point's (distance) or lie within
    ``beta_i`` of them (angles): inside the hull.  Rounding: the targets are widened by
    1e-9 relative and the narrowed bounds outwards by 1e-12 relative.
    """
    dims = pp.slices[0] if hand else slice(pp.slices[1].start, pp.n_dims)
    full_lo, full_hi = _full(pp, lo, hi, dims)
    zc, half = 0.5 * (full_lo + full_hi), 0.5 * (full_hi - full_lo)
    if hand:
        d, (v_a, v_b) = _hand_forms(pp, zc, half)
    else:
        d, v_a, v_b = _object_forms(pp, zc, half)
    d0, d1 = hull.distance
    conditions = [_within(af.dot(d, d), d0 * d0, d1 * d1)]
    for v, (a0, a1) in zip((v_a, v_b), hull.angle):
        c_lo, c_hi = np.cos(a1), np.cos(a0)  # v . d / |d| in [c_lo, c_hi], |d| in [d0, d1]
        conditions.append(_within(af.dot(d, v), min(d0 * c_lo, d1 * c_lo), max(d0 * c_hi, d1 * c_hi)))
    eps_lo, eps_hi = -np.ones_like(full_lo), np.ones_like(full_lo)
    for _ in range(2):
        for g, pad in conditions:
            af.contract_equal(g, pad, eps_lo, eps_hi)
    new_lo = np.maximum(full_lo, zc + half * eps_lo - 1e-12 * np.abs(zc))[:, dims]
    new_hi = np.minimum(full_hi, zc + half * eps_hi + 1e-12 * np.abs(zc))[:, dims]
    return new_lo, new_hi


def _within(f: af.Form, lower: float, upper: float) -> tuple[af.Form, np.ndarray]:
    """``f in [lower, upper]`` as ``|f - mid| <= pad`` (pad widened for rounding)."""
    mid, rad = 0.5 * (lower + upper), 0.5 * (upper - lower)
    scale = np.abs(f.c) + af.spread(f) + abs(mid)
    return af.Form(f.c - mid, f.A, f.rho), rad + _REL_PAD * scale + _REL_PAD


def _scores(pp: PairProblem, forms, lo: np.ndarray, hi: np.ndarray, dims: slice) -> np.ndarray:
    d, v_a, v_b = forms
    size = np.maximum(np.linalg.norm(d.c, axis=1), 1e-9)
    linear = np.linalg.norm(d.A, axis=1) / size[:, None] + np.linalg.norm(v_a.A, axis=1) + np.linalg.norm(v_b.A, axis=1)
    rho = d.rho / size + v_a.rho + v_b.rho
    rel = ((hi - lo) / np.maximum(pp.upper - pp.lower, 1e-12))
    share = rel**2 / np.maximum((rel**2).sum(axis=1, keepdims=True), 1e-300)
    return (linear + rho[:, None] * share)[:, dims]


def _betas(pp: PairProblem) -> tuple[float, float]:
    return tuple(float(pp.hand[s][0].region.half_angle) if isinstance(pp.hand[s][0].region, SphereCap) else 0.0
                 for s in (0, 1))  # fmt: skip


def compatible(hand: SideRanges, obj: SideRanges, betas: tuple[float, float]) -> np.ndarray:
    """``(H, O)``: whether hand box ``i`` and object box ``j`` may hold a grasp of the pair
    (see the module docstring)."""
    col = lambda x: x[:, None]  # noqa: E731
    row = lambda x: x[None, :]  # noqa: E731
    ok = (col(hand.distance[0]) <= row(obj.distance[1])) & (row(obj.distance[0]) <= col(hand.distance[1]))
    for s in (0, 1):
        (t_lo, t_hi), (p_lo, p_hi) = hand.angle[s], obj.angle[s]
        bound = betas[s] + _ANGLE_PAD
        ok &= (col(t_lo) - row(p_hi) <= bound) & (row(p_lo) - col(t_hi) <= bound)
    bound = betas[0] + betas[1] + _ANGLE_PAD
    ok &= (col(hand.between[0]) - row(obj.between[1]) <= bound) & (row(obj.between[0]) - col(hand.between[1]) <= bound)
    return ok & _twist_compatible(hand, obj, betas)


def _twist_compatible(hand: SideRanges, obj: SideRanges, betas: tuple[float, float]) -> np.ndarray:
    """The twist condition of :func:`.congruence.twist_possible` on every pair of boxes ``(H, O)``."""
    col = lambda t: tuple(x[:, None] for x in t)  # noqa: E731
    row = lambda t: tuple(x[None, :] for x in t)  # noqa: E731
    w = [_half_width_upper(col(hand.axial[s]), row(obj.axial[s]), betas[s]) for s in (0, 1)]
    (h_lo, h_hi, h_known), (o_lo, o_hi, o_known) = col(hand.dihedral), row(obj.dihedral)
    lo, hi = o_lo - h_hi, o_hi - h_lo
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    gap = np.maximum(np.abs(np.angle(np.exp(1j * mid))) - half, 0.0)
    apart = h_known & o_known & (half < np.pi) & (gap > w[0] + w[1] + _ANGLE_PAD)
    return ~(apart | (w[0] < 0.0) | (w[1] < 0.0))


def _any_match(hand: SideRanges, obj: SideRanges, betas, chunk_pairs: int = 2_000_000) -> tuple[np.ndarray, np.ndarray]:
    """Which hand boxes and which object boxes have a compatible box on the other side."""
    n_h, n_o = len(hand.distance[0]), len(obj.distance[0])
    h_any, o_any = np.zeros(n_h, dtype=bool), np.zeros(n_o, dtype=bool)
    if not n_h or not n_o:
        return h_any, o_any
    # sort the object boxes by their distance floor: a hand box meets only those below its ceiling
    order = np.argsort(obj.distance[0], kind="stable")
    floors = obj.distance[0][order]
    step = max(1, chunk_pairs // n_o)
    for start in range(0, n_h, step):
        rows = np.arange(start, min(n_h, start + step))
        part = hand.rows(rows)
        reach = np.searchsorted(floors, part.distance[1].max(), side="right")
        cand = order[:reach]
        if not len(cand):
            continue
        ok = compatible(part, obj.rows(cand), betas)
        h_any[rows] = ok.any(axis=1)
        o_any[cand] |= ok.any(axis=0)
    return h_any, o_any


def prove_pair_by_matching(pp: PairProblem, *, max_boxes: int = 200_000, time_limit_s: float | None = None,
                           witness_width: float = 1e-7, hand_share: float = 0.5, max_pairs: int = MAX_PAIRS) -> PairOutcome:  # fmt: skip
    """Branch and prune of the two sides separately, matched by their invariants' ranges (see
    the module docstring); ``max_boxes`` counts the boxes evaluated on both sides (a round
    that would pass it is not begun).  Each
    round splits every surviving box of the side whose count is below ``hand_share`` (hand)
    or ``1 - hand_share`` (object) of the total; "witness" when both sides' surviving boxes
    are narrower than ``witness_width`` (relative) and still match; "budget" also when the
    next round would match more than ``max_pairs`` pairs of boxes."""
    started = time.perf_counter()
    betas = _betas(pp)
    h_dims, o_dims = pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    h_scale = np.maximum(pp.upper[h_dims] - pp.lower[h_dims], 1e-12)
    o_scale = np.maximum(pp.upper[o_dims] - pp.lower[o_dims], 1e-12)
    h_lo, h_hi = pp.lower[None, h_dims].copy(), pp.upper[None, h_dims].copy()
    o_lo, o_hi = pp.lower[None, o_dims].copy(), pp.upper[None, o_dims].copy()
    h_rng, h_score = hand_ranges(pp, h_lo, h_hi)
    o_rng, o_score = object_ranges(pp, o_lo, o_hi)
    boxes = 2
    while True:
        h_keep, o_keep = _any_match(h_rng, o_rng, betas)
        h_lo, h_hi, h_score, h_rng = h_lo[h_keep], h_hi[h_keep], h_score[h_keep], h_rng.rows(h_keep)
        o_lo, o_hi, o_score, o_rng = o_lo[o_keep], o_hi[o_keep], o_score[o_keep], o_rng.rows(o_keep)
        if not len(h_lo):
            return PairOutcome(True, boxes, time.perf_counter() - started)
        h_narrow = ((h_hi - h_lo) / h_scale).max(axis=1, initial=0.0).min() < witness_width
        o_narrow = ((o_hi - o_lo) / o_scale).max(axis=1, initial=0.0).min() < witness_width
        if h_narrow and o_narrow:
            return PairOutcome(False, boxes, time.perf_counter() - started, "witness")
        split_hand = not h_narrow and (o_narrow or len(h_lo) <= hand_share * (len(h_lo) + len(o_lo)))
        more = 2 * (len(h_lo) if split_hand else len(o_lo))
        pairs = len(h_lo) * len(o_lo) * (2 if more else 1)
        if boxes + more > max_boxes or pairs > max_pairs or (time_limit_s is not None and time.perf_counter() - started > time_limit_s):
            return PairOutcome(False, boxes, time.perf_counter() - started, "budget")
        if split_hand:
            h_lo, h_hi, h_score = _narrowed(pp, h_lo, h_hi, h_score, hull_of(o_rng, betas), hand=True)
            h_lo, h_hi = _halves(h_lo, h_hi, h_score, h_scale)
            h_rng, h_score = hand_ranges(pp, h_lo, h_hi)
            boxes += len(h_lo)
        else:
            o_lo, o_hi, o_score = _narrowed(pp, o_lo, o_hi, o_score, hull_of(h_rng, betas), hand=False)
            o_lo, o_hi = _halves(o_lo, o_hi, o_score, o_scale)
            o_rng, o_score = object_ranges(pp, o_lo, o_hi)
            boxes += len(o_lo)


def _narrowed(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, score: np.ndarray, hull: Hull, *, hand: bool):
    """The boxes narrowed by :func:`contract_to` (emptied ones dropped) with their scores."""
    lo, hi = contract_to(pp, lo, hi, hull, hand=hand)
    keep = (lo <= hi).all(axis=1)
    return lo[keep], hi[keep], score[keep]
