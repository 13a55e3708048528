r"""The pair test by matching ranges: each side's pose-free invariants bounded on its own boxes.

The pair test of :mod:`.product` searches the *product* of the pair's joint angles and
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
:func:`.product.twist_possible`).  Bounding each side's invariants over its own boxes
and keeping the pairs of boxes whose ranges allow these relations (:func:`compatible`)
discards exactly what the product test's separate checks discard on the product of the
two boxes, but the subdivisions add up instead of multiplying: the hand side is split
over its angles only and the object side over its parameters only.

:func:`prove_pair_by_matching` alternates: match, drop the boxes of either side that no box
of the other side matches, narrow the survivors of one side to the hull of the other side's
ranges (:func:`contract_to`), split them (the side with fewer boxes, through the dimension
that moves its invariants most).  No hand box left: the pair,
hence the task, cannot be made (for any number of contacts).  With a budget from
:data:`EXTREMES_FROM`, it first bounds the object side's invariants over its whole domain
(:func:`object_extremes`, best-first searches of four dimensions at most), searches the hand
side alone against that one row of ranges (:func:`hand_against`), and clips every object
box's ranges to it (:func:`clip_to`).  Angles near 0 and pi are bounded through their sine
(:func:`_sharper`).  Rounding: every range is widened outwards (relative 1e-9 on lengths,
sines and cosines, 1e-7 rad on the angle tests).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from . import affine as af
from .forms import axial_bounds, dihedral_bounds, half_width_upper, hand_forms, interval, length_bounds, object_forms
from .problem import PairOutcome, PairProblem, halves
from .span import best_first_max

__all__ = ["EXTREME_BOXES", "EXTREME_TOL", "EXTREMES_FROM", "MAX_PAIRS", "SideRanges", "Hull", "hand_ranges",
           "object_ranges", "compatible", "hull_of", "contract_to", "object_extremes", "clip_to", "hand_against",
           "prove_pair_by_matching"]

REL_PAD = 1e-9
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
    return np.clip(lo - (REL_PAD * np.abs(lo) + REL_PAD), -1.0, 1.0), np.clip(hi + (REL_PAD * np.abs(hi) + REL_PAD), -1.0, 1.0)


def _angles(cos: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return np.arccos(cos[1]), np.arccos(cos[0])


def _ranges(d: af.Form, v_a: af.Form, v_b: af.Form, *, dihedral: bool = True) -> SideRanges:
    """Invariant ranges of ``d`` and the two unit vectors ``v_a, v_b`` (forms over the boxes);
    the dihedral angle left unknown unless ``dihedral``."""
    length = length_bounds(d)
    squared = interval(af.dot(d, d))  # the term-by-term quadratic: often tighter than |c| -+ spread
    n = d.c / np.maximum(np.linalg.norm(d.c, axis=1), 1e-300)[:, None]
    projected = np.linalg.norm(d.c, axis=1) - np.abs(np.einsum("bi,bik->bk", n, d.A)).sum(axis=1) - d.rho
    lower = np.maximum.reduce([length[0], projected, np.sqrt(np.maximum(squared[0], 0.0))])
    upper = np.minimum(length[1], np.sqrt(np.maximum(squared[1], 0.0)))
    distance = (np.maximum(lower * (1.0 - REL_PAD) - REL_PAD, 0.0), upper * (1.0 + REL_PAD) + REL_PAD)
    axial, angle = [], []
    for v in (v_a, v_b):
        cos = _cos_interval(*axial_bounds(d, v, length))
        a = _sharper(_angles(cos), cos, _sine(af.cross(v, d), length))
        axial.append((np.maximum(cos[0], np.cos(a[1])), np.minimum(cos[1], np.cos(a[0]))))
        angle.append(a)
    cos = _cos_interval(*interval(af.dot(v_a, v_b)))
    between = _sharper(_angles(cos), cos, _sine(af.cross(v_a, v_b), (np.ones(len(cos[0])), np.ones(len(cos[0])))))
    B = len(distance[0])
    unknown = (np.full(B, -np.pi), np.full(B, np.pi), np.zeros(B, dtype=bool))
    return SideRanges(distance, tuple(axial), tuple(angle), between, dihedral_bounds(d, v_a, v_b, length) if dihedral else unknown)


def _sine(x: af.Form, length: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``|x| / L`` (the sine of an angle, ``x`` the cross product of a unit vector
    with a vector of length ``L in length``), widened outwards for rounding."""
    x_lo, x_hi = length_bounds(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        s_lo = np.where(length[1] > 0.0, x_lo / length[1], 0.0)
        s_hi = np.where(length[0] > 0.0, x_hi / length[0], 1.0)
    return np.clip(s_lo * (1.0 - REL_PAD) - REL_PAD, 0.0, 1.0), np.clip(s_hi * (1.0 + REL_PAD) + REL_PAD, 0.0, 1.0)


def _sharper(angle: tuple, cos: tuple, sine: tuple) -> tuple[np.ndarray, np.ndarray]:
    """An angle's bounds ``[0, pi]`` from its cosine's intersected with those from its sine,
    where the cosine's sign is certain: near 0 and pi the sine is the well-conditioned one
    (guitar-tuning's contact normals lie within 17 degrees of ``d``, where the cosine bound,
    divided by ``|d|``'s range, is several degrees looser).  Widened by 1e-7 rad."""
    lo, hi = angle
    near, far = np.arcsin(sine[0]), np.arcsin(sine[1])
    acute, obtuse = cos[0] > 0.0, cos[1] < 0.0
    lo = np.where(acute, np.maximum(lo, near - _ANGLE_PAD), np.where(obtuse, np.maximum(lo, np.pi - far - _ANGLE_PAD), lo))
    hi = np.where(acute, np.minimum(hi, far + _ANGLE_PAD), np.where(obtuse, np.minimum(hi, np.pi - near + _ANGLE_PAD), hi))
    return np.maximum(lo, 0.0), np.minimum(hi, np.pi)


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
    d, (m_a, m_b) = hand_forms(pp, zc, half)
    ranges = _ranges(d, m_a, m_b)
    upper, _ = pp.kin.distance_upper_mm(lo, hi)  # the span search's bound: quadratic near the maximum
    ranges = SideRanges((ranges.distance[0], np.minimum(ranges.distance[1], upper * (1.0 + REL_PAD) + REL_PAD)),
                        ranges.axial, ranges.angle, ranges.between, ranges.dihedral)  # fmt: skip
    return ranges, _scores(pp, (d, m_a, m_b), full_lo, full_hi, pp.slices[0])


def object_ranges(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, *, dihedral: bool = True) -> tuple[SideRanges, np.ndarray]:  # fmt: skip
    """The object side's ranges over boxes of the two regions' parameters ``(B, p)`` (``d``
    between the fingertip centres ``o + r nu`` when touching, ``h = -nu``) and split scores
    (the dihedral angle left unknown unless ``dihedral``)."""
    dims = slice(pp.slices[1].start, pp.n_dims)
    full_lo, full_hi = _full(pp, lo, hi, dims)
    zc, half = 0.5 * (full_lo + full_hi), 0.5 * (full_hi - full_lo)
    d, h_a, h_b = object_forms(pp, zc, half)
    return _ranges(d, h_a, h_b, dihedral=dihedral), _scores(pp, (d, h_a, h_b), full_lo, full_hi, dims)


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
        d, (v_a, v_b) = hand_forms(pp, zc, half)
    else:
        d, v_a, v_b = object_forms(pp, zc, half)
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
    return af.Form(f.c - mid, f.A, f.rho), rad + REL_PAD * scale + REL_PAD


def _scores(pp: PairProblem, forms, lo: np.ndarray, hi: np.ndarray, dims: slice) -> np.ndarray:
    d, v_a, v_b = forms
    size = np.maximum(np.linalg.norm(d.c, axis=1), 1e-9)
    linear = np.linalg.norm(d.A, axis=1) / size[:, None] + np.linalg.norm(v_a.A, axis=1) + np.linalg.norm(v_b.A, axis=1)
    rho = d.rho / size + v_a.rho + v_b.rho
    rel = ((hi - lo) / np.maximum(pp.upper - pp.lower, 1e-12))
    share = rel**2 / np.maximum((rel**2).sum(axis=1, keepdims=True), 1e-300)
    return (linear + rho[:, None] * share)[:, dims]


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
    """The twist condition of :func:`.product.twist_possible` on every pair of boxes ``(H, O)``."""
    col = lambda t: tuple(x[:, None] for x in t)  # noqa: E731
    row = lambda t: tuple(x[None, :] for x in t)  # noqa: E731
    w = [half_width_upper(col(hand.axial[s]), row(obj.axial[s]), betas[s]) for s in (0, 1)]
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


# -- the object side's extremes: one tight set of ranges for the hand side ---------------------------
#: Per extreme of the object side's invariants (:func:`object_extremes`): at most this many
#: boxes of the regions' parameters (four dimensions, no kinematics: ~0.15 ms each with the
#: patches' local remainders); :func:`prove_pair_by_matching` gives each an eighth of its
#: budget up to this (guitar-holding's first pair test, six pairs of ~800 boxes each, spent
#: 1.8 s per pair on 3,000-box extremes that a feasible pair cannot use).
EXTREME_BOXES = 3_000

#: :func:`prove_pair_by_matching` starts with the extremes and the hand stage only from this
#: budget on: the complete search's late pair test (40,000 boxes for one pair), not its
#: first (a tenth of that, shared by the pairs), where a feasible task such as
#: guitar-holding would pay for them (+2.5 s CPU over six pairs) and gain nothing.
EXTREMES_FROM = 20_000

#: The extremes stop within this of the best value met at a box centre [mm, rad].
EXTREME_TOL = (0.01, 1e-3)


def _extreme(pp: PairProblem, pick, sense: float, tol: float, max_boxes: int) -> tuple[float, int]:
    """``(bound, boxes)``: a proven bound of the largest (``sense`` +1) or smallest (-1) value of
    one object-side invariant over the regions' parameters (:func:`.span.best_first_max`);
    ``pick(SideRanges)`` gives its ``(lower, upper)`` per box."""
    dims = slice(pp.slices[1].start, pp.n_dims)

    def upper_of(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        ranges = pick(object_ranges(pp, lo[:, dims], hi[:, dims], dihedral=False)[0])
        return ranges[1] if sense > 0.0 else -ranges[0]

    bound, _, boxes = best_first_max(pp, upper_of, lambda best: tol, max_boxes)
    return sense * bound, boxes


#: The extremes :func:`object_extremes` searches: the distance's floor (the hand must reach
#: it) and both ends of each side's angle of ``d`` with the normal (the cone conditions).
#: The distance's ceiling and the angle between the normals keep the whole domain's
#: one-box bounds: the hand's span already caps the first, and the second is compared
#: within ``beta_a + beta_b`` (120 degrees for two fingertip caps), so narrowing them
#: rarely pays for their searches (~3,000 boxes, 0.6 s each on guitar-tuning's key).
_SEARCHED = frozenset({("distance", -1.0), ("a", -1.0), ("a", 1.0), ("b", -1.0), ("b", 1.0)})


def object_extremes(pp: PairProblem, *, max_boxes: int = EXTREME_BOXES, tol: tuple[float, float] = EXTREME_TOL,
                    distance_floor_mm: float | None = None) -> tuple[SideRanges, int]:  # fmt: skip
    """One row of ranges holding the object side's invariants over the *whole* parameter
    domain -- distance, each side's angle of ``d`` with the normal, the angle between the
    normals -- and the boxes used.  The ends in :data:`_SEARCHED` are bounded by their own
    search (:func:`_extreme`, ``max_boxes`` each, within ``tol`` = (mm, rad) of the
    extreme), the others by one box.  ``distance_floor_mm``: a proven floor of the distance
    already at hand (:func:`.span.object_distance_floor`), used instead of searching
    it again.  Tighter by far than one box's ranges: the affine enclosure's quadratic
    remainder shrinks only with the boxes, and the extremes need small boxes only near
    where they are met (guitar-tuning's key at t* + 2 mm: distance floor 210.5639 mm in
    ~8,000 boxes, true 210.5640; the one-box enclosure of the whole domain is ~380 mm
    wide).  The dihedral angle is left unknown."""
    dims = slice(pp.slices[1].start, pp.n_dims)
    root = object_ranges(pp, pp.lower[None, dims], pp.upper[None, dims])[0]
    found: dict = {}
    boxes = 1
    picks = {"distance": lambda r: r.distance, "a": lambda r: r.angle[0], "b": lambda r: r.angle[1], "between": lambda r: r.between}
    for name, pick in picks.items():
        for sense in (-1.0, 1.0):
            found[name, sense] = float(pick(root)[0 if sense < 0.0 else 1][0])
            if (name, sense) not in _SEARCHED:
                continue
            if name == "distance" and distance_floor_mm is not None:
                found[name, sense] = max(found[name, sense], distance_floor_mm)
                continue
            value, used = _extreme(pp, pick, sense, tol[0] if name == "distance" else tol[1], max_boxes)
            found[name, sense] = max(found[name, sense], value) if sense < 0.0 else min(found[name, sense], value)
            boxes += used
    one = lambda name: (np.array([found[name, -1.0]]), np.array([found[name, 1.0]]))  # noqa: E731
    angles = (one("a"), one("b"))
    axial = tuple(_cos_interval(np.cos(a[1]), np.cos(a[0])) for a in angles)
    unknown = (np.array([-np.pi]), np.array([np.pi]), np.array([False]))
    return SideRanges(one("distance"), axial, angles, one("between"), unknown), boxes


def clip_to(ranges: SideRanges, bound: SideRanges) -> SideRanges:
    """Every box's ranges intersected with ``bound``'s single row (ranges that hold over the
    whole domain of that side, :func:`object_extremes`): sound, as each box's points lie in
    both.  The dihedral angle is kept."""
    cut = lambda r, b: (np.maximum(r[0], b[0][0]), np.minimum(r[1], b[1][0]))  # noqa: E731
    return SideRanges(cut(ranges.distance, bound.distance), tuple(cut(r, b) for r, b in zip(ranges.axial, bound.axial)),
                      tuple(cut(r, b) for r, b in zip(ranges.angle, bound.angle)), cut(ranges.between, bound.between),
                      ranges.dihedral)  # fmt: skip


def hand_against(pp: PairProblem, target: SideRanges, *, max_boxes: int, time_limit_s: float | None = None,
                 started: float | None = None) -> tuple[bool, np.ndarray, np.ndarray, int]:  # fmt: skip
    """Branch and prune of the hand side alone against one row of object ranges ``target``
    (:func:`object_extremes`): ``(proved, lo, hi, boxes)``, ``lo, hi`` the surviving boxes of
    the pair's angles (every hand configuration that ``target`` matches lies in one).  Each
    round narrows the boxes to the target's hull (:func:`contract_to`) and splits them all;
    it stops before a round that would pass ``max_boxes`` or ``time_limit_s``."""
    started = time.perf_counter() if started is None else started
    betas = pp.betas
    dims = pp.slices[0]
    scale = np.maximum(pp.upper[dims] - pp.lower[dims], 1e-12)
    hull = hull_of(target, betas)
    lo, hi = pp.lower[None, dims].copy(), pp.upper[None, dims].copy()
    ranges, score = hand_ranges(pp, lo, hi)
    boxes = 1
    while True:
        keep, _ = _any_match(ranges, target, betas)
        lo, hi, score, ranges = lo[keep], hi[keep], score[keep], ranges.rows(keep)
        if not len(lo):
            return True, lo, hi, boxes
        over = time_limit_s is not None and time.perf_counter() - started > time_limit_s
        if boxes + 2 * len(lo) > max_boxes or over:
            return False, lo, hi, boxes
        lo, hi, score = _narrowed(pp, lo, hi, score, hull, hand=True)
        lo, hi = halves(lo, hi, score, scale)
        ranges, score = hand_ranges(pp, lo, hi)
        boxes += len(lo)


def prove_pair_by_matching(pp: PairProblem, *, max_boxes: int = 200_000, time_limit_s: float | None = None,
                           witness_width: float = 1e-7, hand_share: float = 0.5, max_pairs: int = MAX_PAIRS,
                           distance_floor_mm: float | None = None) -> PairOutcome:  # fmt: skip
    """Branch and prune of the two sides separately, matched by their invariants' ranges (see
    the module docstring); ``max_boxes`` counts the boxes evaluated on both sides (a round
    that would pass it is not begun), apart from the object side's extremes
    (:func:`object_extremes`, an eighth of ``max_boxes`` each, at most :data:`EXTREME_BOXES`;
    ``distance_floor_mm`` is a proven floor of the object side's distance).  From a budget of
    :data:`EXTREMES_FROM` boxes, first the hand side alone is searched against those extremes
    (:func:`hand_against`, at most a quarter of ``max_boxes``, half of the time): what decides
    guitar-tuning's key from t* + 2 mm, where no box of the object side is ever dropped but
    the object's extremes leave no hand configuration.  Then the matching starts from the
    hand boxes left, every object box's ranges clipped to the extremes (:func:`clip_to`).
    Each
    round splits every surviving box of the side whose count is below ``hand_share`` (hand)
    or ``1 - hand_share`` (object) of the total; "witness" when both sides' surviving boxes
    are narrower than ``witness_width`` (relative) and still match; "budget" also when the
    next round would match more than ``max_pairs`` pairs of boxes."""
    started = time.perf_counter()
    betas = pp.betas
    h_dims, o_dims = pp.slices[0], slice(pp.slices[1].start, pp.n_dims)
    h_scale = np.maximum(pp.upper[h_dims] - pp.lower[h_dims], 1e-12)
    o_scale = np.maximum(pp.upper[o_dims] - pp.lower[o_dims], 1e-12)
    o_lo, o_hi = pp.lower[None, o_dims].copy(), pp.upper[None, o_dims].copy()
    proved, tight, h_lo, h_hi, boxes, extra = _hand_first(pp, max_boxes, time_limit_s, distance_floor_mm, started)
    if proved:
        return PairOutcome(True, boxes, time.perf_counter() - started)
    clip = (lambda r: r) if tight is None else (lambda r: clip_to(r, tight))  # noqa: E731
    h_rng, h_score = hand_ranges(pp, h_lo, h_hi)
    o_rng, o_score = object_ranges(pp, o_lo, o_hi)
    o_rng = clip(o_rng)
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
        if boxes - extra + more > max_boxes or pairs > max_pairs or (time_limit_s is not None and time.perf_counter() - started > time_limit_s):
            return PairOutcome(False, boxes, time.perf_counter() - started, "budget")
        if split_hand:
            h_lo, h_hi, h_rng, h_score = _refined(pp, h_lo, h_hi, h_score, hull_of(o_rng, betas), h_scale, hand=True)
            boxes += len(h_lo)
        else:
            o_lo, o_hi, o_rng, o_score = _refined(pp, o_lo, o_hi, o_score, hull_of(h_rng, betas), o_scale, hand=False)
            o_rng = clip(o_rng)
            boxes += len(o_lo)


def _hand_first(pp: PairProblem, max_boxes: int, time_limit_s: float | None, distance_floor_mm: float | None,
                started: float) -> tuple[bool, SideRanges | None, np.ndarray, np.ndarray, int, int]:  # fmt: skip
    """The first stage of :func:`prove_pair_by_matching`: ``(proved, extremes, h_lo, h_hi, boxes,
    extra)``.  From a budget of :data:`EXTREMES_FROM`, the hand alone against the object
    side's extremes (their own budget, ``extra`` boxes; the hand at most a quarter of
    ``max_boxes``: refined further, its boxes only multiply the pairs the matching must then
    make -- guitar-tuning at t* + 1 mm: proved in 18,779 boxes with 10,000 for the hand
    alone, in 23,461 with 20,000, in 77,401 with 100,000); below it, the hand's whole box."""
    h_dims = pp.slices[0]
    h_lo, h_hi = pp.lower[None, h_dims].copy(), pp.upper[None, h_dims].copy()
    if max_boxes < EXTREMES_FROM:
        return False, None, h_lo, h_hi, 2, 0
    tight, extra = object_extremes(pp, max_boxes=min(EXTREME_BOXES, max_boxes // 8), distance_floor_mm=distance_floor_mm)
    half_time = None if time_limit_s is None else 0.5 * time_limit_s
    proved, h_lo, h_hi, used = hand_against(pp, tight, max_boxes=max_boxes // 4, time_limit_s=half_time, started=started)
    return proved, tight, h_lo, h_hi, extra + used + 1, extra  # the extremes' boxes are reported, not counted in ``max_boxes``


def _refined(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, score: np.ndarray, hull: Hull, scale: np.ndarray, *,
             hand: bool) -> tuple[np.ndarray, np.ndarray, SideRanges, np.ndarray]:  # fmt: skip
    """One side's boxes narrowed to the other side's hull, split, and their new ranges and scores."""
    lo, hi, score = _narrowed(pp, lo, hi, score, hull, hand=hand)
    lo, hi = halves(lo, hi, score, scale)
    ranges, score = hand_ranges(pp, lo, hi) if hand else object_ranges(pp, lo, hi)
    return lo, hi, ranges, score


def _narrowed(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, score: np.ndarray, hull: Hull, *, hand: bool):
    """The boxes narrowed by :func:`contract_to` (emptied ones dropped) with their scores."""
    lo, hi = contract_to(pp, lo, hi, hull, hand=hand)
    keep = (lo <= hi).all(axis=1)
    return lo[keep], hi[keep], score[keep]
