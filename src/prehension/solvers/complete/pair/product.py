"""The product test: branch and prune over the product of the pair's joint angles and its
object regions' parameters (see :mod:`prehension.solvers.complete.pair`)."""

from __future__ import annotations

import time

import numpy as np

from . import affine as af
from .forms import (axial_bounds, dihedral_bounds, half_width_upper, hand_forms, length_bounds, norm_upper,
                    object_forms, vector_spread)  # fmt: skip
from .problem import REL_PAD, PairOutcome, PairProblem, halves

__all__ = ["NEAR_SPAN_MM", "TWIST_RELATIVE_SPREAD", "prove_pair_infeasible", "twist_possible"]


#: Within this distance [mm] of the object side's floor, the pair test's boxes are split by
#: its conditions; farther, through an angle for the hand's distance (``distance_floor_mm``
#: of :func:`prove_pair_infeasible`).
NEAR_SPAN_MM = 1.0

#: The twist condition (:func:`twist_possible`) is evaluated on a box only when the hand
#: side's ``d`` varies over it by less than this fraction of its length: on wider boxes its
#: interval bounds of the dihedral angles are too loose to prune (the lid at t* + 2 mm: every
#: box it pruned varied by under 0.036 |d|), and it costs as much as the other conditions.
TWIST_RELATIVE_SPREAD = 0.05


def _cone_condition(axis: af.Form, d: tuple[af.Form, af.Form], h: af.Form, cos_b: float, sin_b: float) -> af.Form:
    """``axis . d_hand - cos(beta) (d . h) + sin(beta) |d x h| >= 0`` (object ``d`` and ``h``),
    i.e. ``angle(d, axis) <= angle(d, h) + beta``; ``|d x h|`` enters through its upper bound
    on the box.  The cosine bound needs ``angle(d, h) + beta <= pi``: on boxes where that is
    not certain (``d . h >= -|d| cos(beta)`` not proven) the condition is dropped."""
    kappa = af.dot(d[1], h)
    f = af.sub(af.dot(axis, d[0]), _scaled(kappa, cos_b))
    # d . h >= -|d| cos(beta) on the whole box: with cos(beta) >= 0 the lower bound of |d|
    # makes it certain, with cos(beta) < 0 (beta > 90 deg) its upper bound
    d_size = length_bounds(d[1])[0] if cos_b >= 0.0 else norm_upper(d[1])
    valid = kappa.c - af.spread(kappa) + d_size * cos_b >= 0.0
    return af.Form(np.where(valid, f.c + sin_b * norm_upper(af.cross(d[1], h)), np.inf), f.A, f.rho)


def _scaled(f: af.Form, s: float) -> af.Form:
    return af.Form(f.c * s, f.A * s, f.rho * abs(s))


def _conditions(pp: PairProblem, lo: np.ndarray, hi: np.ndarray):
    """Equations ``(form, pad)`` (``= 0``) and inequalities (``>= 0``) on the boxes, and the
    forms ``(d_hand, dirs, d_obj, normals)`` of the twist condition (:func:`twist_possible`)."""
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d_hand, dirs = hand_forms(pp, zc, half)
    d_obj, h_a, h_b = object_forms(pp, zc, half, local=False)
    equations, inequalities = _form_conditions(pp, d_hand, dirs, d_obj, h_a, h_b)
    return equations, inequalities, (d_hand, dirs, d_obj, (h_a, h_b))


def _rows(f: af.Form, rows: np.ndarray) -> af.Form:
    return af.Form(f.c[rows], f.A[rows], f.rho[rows])


def _form_conditions(pp: PairProblem, d_hand: af.Form, dirs: list, d_obj: af.Form, h_a: af.Form, h_b: af.Form):
    equations = [_difference(af.dot(d_hand, d_hand), af.dot(d_obj, d_obj))]
    inequalities = []
    caps = pp.caps
    for side, (h, sign) in enumerate(((h_a, 1.0), (h_b, -1.0))):
        d_h, d_o = (d_hand, d_obj) if sign > 0 else (af.neg(d_hand), af.neg(d_obj))
        if caps[side]:
            beta = pp.betas[side]
            inequalities.append(_pad(_cone_condition(dirs[side], (d_h, d_o), h, np.cos(beta), np.sin(beta))))
        else:
            equations.append(_difference(af.dot(d_h, dirs[side]), af.dot(d_o, h)))
    if not any(caps):
        equations.append(_difference(af.dot(dirs[0], dirs[1]), af.dot(h_a, h_b)))
        equations.append(_difference(af.dot(d_hand, af.cross(dirs[0], dirs[1])), af.dot(d_obj, af.cross(h_a, h_b))))
    else:
        total = sum(pp.betas[s] for s in (0, 1) if caps[s])
        if total < np.pi:  # angle(m_a, m_b) <= angle(h_a, h_b) + beta_a + beta_b
            gamma = af.dot(h_a, h_b)
            f = af.sub(af.dot(dirs[0], dirs[1]), _scaled(gamma, np.cos(total)))
            valid = gamma.c - af.spread(gamma) + np.cos(total) >= 0.0  # angle(h_a, h_b) + total <= pi
            c = np.where(valid, f.c + np.sin(total) * norm_upper(af.cross(h_a, h_b)), np.inf)
            inequalities.append(_pad(af.Form(c, f.A, f.rho)))
    return equations, inequalities


def _difference(P: af.Form, O: af.Form):
    scale = np.abs(P.c) + np.abs(O.c) + af.spread(P) + af.spread(O)
    return af.sub(P, O), REL_PAD * scale + REL_PAD


def _pad(f: af.Form):
    return f, REL_PAD * (np.abs(f.c) + af.spread(f)) + REL_PAD


# -- the twist about the line between the fingertip centres -----------------------------------------

def twist_possible(pp: PairProblem, d_hand: af.Form, dirs: list, d_obj: af.Form, normals: tuple) -> np.ndarray:
    """Whether one rotation can meet both cones, per box ``(B,)``.

    The rotations taking the hand side's ``d`` onto the object side's (every grasp makes one)
    differ by a twist ``psi`` about ``d``.  Side ``i``'s cone (the normal ``h_i`` within
    ``beta_i`` of the cap's axis ``m_i``; ``beta = 0`` for a hand point) holds on an arc of
    ``psi`` of half width ``w_i`` (:func:`.forms.half_width_upper`) centred at the azimuth of ``h_i``
    minus that of ``m_i`` about ``d``; the two arcs meet only if the dihedral angle of the
    planes ``(d, h_a), (d, h_b)`` (object side) is within ``w_a + w_b`` of that of ``(d, m_a),
    (d, m_b)`` (hand side), on the circle.  The cone conditions of :func:`_cone_condition`
    ask each arc to exist; this asks them to meet -- what makes the pair test exact for
    two fingertip caps on patches, where each cone alone can be met near the frontier but
    not both with the same pose.  Bounds are intervals from the affine forms, outward, with
    a margin of 1e-7 rad.
    """
    betas = pp.betas
    L_hand, L_obj = length_bounds(d_hand), length_bounds(d_obj)
    w = [half_width_upper(axial_bounds(d_hand, dirs[s], L_hand), axial_bounds(d_obj, normals[s], L_obj), betas[s]) for s in (0, 1)]
    hand_lo, hand_hi, hand_known = dihedral_bounds(d_hand, dirs[0], dirs[1], L_hand)
    obj_lo, obj_hi, obj_known = dihedral_bounds(d_obj, normals[0], normals[1], L_obj)
    lo, hi = obj_lo - hand_hi, obj_hi - hand_lo  # the centres' difference
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    gap = np.maximum(np.abs(np.angle(np.exp(1j * mid))) - half, 0.0)
    apart = hand_known & obj_known & (half < np.pi) & (gap > w[0] + w[1] + 1e-7)
    none = (w[0] < 0.0) | (w[1] < 0.0)
    return ~(apart | none)


# -- branch and prune ----------------------------------------------------------------------------------
def prove_pair_infeasible(pp: PairProblem, *, max_boxes: int = 200_000, time_limit_s: float | None = None,
                          witness_width: float = 1e-7, batch: int = 256, distance_floor_mm: float = 0.0) -> PairOutcome:  # fmt: skip
    """Branch and prune over the pair's box (see the module docstring); stops without a
    proof after ``max_boxes`` boxes or ``time_limit_s`` seconds (None: no time limit).

    ``distance_floor_mm``: a proven lower bound of ``|c_b - c_a|`` over the whole object
    side (:func:`.span.object_distance_floor`; 0: none).  The hand's distance must reach it:
    a box of angles whose span bound (:meth:`PairKinematics.distance_upper_mm`) stays
    below it is discarded, and a box whose bound exceeds it by more than
    :data:`NEAR_SPAN_MM` is split through an angle, by the span search's rule.  The object
    side is then not split where only the angles can decide (splitting both multiplies
    the boxes), and near the frontier the search is left with the few configurations near
    the hand's widest, where the cone conditions decide.
    """
    started = time.perf_counter()
    scale = np.maximum(pp.upper - pp.lower, 1e-12)
    stack_lo, stack_hi = [pp.lower[None].copy()], [pp.upper[None].copy()]
    boxes = 0
    while stack_lo:
        lo, hi = _take(stack_lo, stack_hi, batch)
        boxes += len(lo)
        lo, hi, split, score = _prune_and_contract(pp, lo, hi, distance_floor_mm)
        if len(lo) and np.any(((hi - lo) / scale).max(axis=1) < witness_width):
            k = int(np.argmin(((hi - lo) / scale).max(axis=1)))
            return PairOutcome(False, boxes, time.perf_counter() - started, "witness", 0.5 * (lo[k] + hi[k]))
        _push(stack_lo, stack_hi, lo[~split], hi[~split])
        _push(stack_lo, stack_hi, *halves(lo[split], hi[split], score[split], scale))
        if boxes >= max_boxes or (time_limit_s is not None and time.perf_counter() - started > time_limit_s):
            return PairOutcome(False, boxes, time.perf_counter() - started, "budget")
    return PairOutcome(True, boxes, time.perf_counter() - started)


def _take(stack_lo: list, stack_hi: list, batch: int) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = stack_lo.pop(), stack_hi.pop()
    if len(lo) > batch:
        stack_lo.append(lo[:-batch])
        stack_hi.append(hi[:-batch])
        lo, hi = lo[-batch:], hi[-batch:]
    return lo, hi


def _push(stack_lo: list, stack_hi: list, lo: np.ndarray, hi: np.ndarray) -> None:
    if len(lo):
        stack_lo.append(lo)
        stack_hi.append(hi)


def _prune_and_contract(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, distance_floor_mm: float = 0.0):
    """Drop the boxes that cannot hold a solution, narrow the others; returns the kept boxes,
    which of them to split (the others narrowed enough to be evaluated again) and the
    split scores ``(B, K)`` (see ``distance_floor_mm`` of :func:`prove_pair_infeasible`)."""
    far = np.zeros(len(lo), dtype=bool)
    if distance_floor_mm > 0.0:
        sa = pp.slices[0]
        reach, reach_score = pp.kin.distance_upper_mm(lo[:, sa], hi[:, sa])
        reach = reach * (1.0 + REL_PAD) + REL_PAD
        near = reach >= distance_floor_mm
        lo, hi, reach, reach_score = lo[near], hi[near], reach[near], reach_score[near]
        far = reach > distance_floor_mm + NEAR_SPAN_MM
    equations, cones, (d_hand, dirs, d_obj, normals) = _conditions(pp, lo, hi)
    alive = np.ones(len(lo), dtype=bool)
    for g, pad in equations:
        alive &= np.abs(g.c) <= af.spread(g) + pad
    for f, pad in cones:
        alive &= f.c + af.spread(f) + pad >= 0.0
    # the twist condition only where the others hold and the box is narrow enough for it to
    # prune (it costs as much again; a choice of effort, not of soundness)
    rows = np.flatnonzero(alive & (vector_spread(d_hand) < TWIST_RELATIVE_SPREAD * np.linalg.norm(d_hand.c, axis=1)))
    if len(rows):
        alive[rows] = twist_possible(pp, _rows(d_hand, rows), [_rows(v, rows) for v in dirs], _rows(d_obj, rows),
                                     tuple(_rows(v, rows) for v in normals))  # fmt: skip
    eps_lo, eps_hi = -np.ones_like(lo), np.ones_like(lo)
    for _ in range(2):
        for g, pad in equations:
            af.contract_equal(g, pad, eps_lo, eps_hi)
        for f, pad in cones:
            af.contract_at_least(f, pad, eps_lo, eps_hi)
    alive &= np.all(eps_lo <= eps_hi, axis=1)
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    new_lo = np.maximum(lo, zc + half * eps_lo - 1e-12 * np.abs(zc))
    new_hi = np.minimum(hi, zc + half * eps_hi + 1e-12 * np.abs(zc))
    shrunk = ((new_hi - new_lo) < 0.7 * (hi - lo)) & (hi - lo > 0)
    score = _split_scores(equations, cones, (hi - lo) / np.maximum(pp.upper - pp.lower, 1e-12))
    if far.any():  # the angles alone decide these boxes: split them for the distance
        score[far] = 0.0
        score[np.ix_(far, np.arange(pp.slices[0].start, pp.slices[0].stop))] = 1.0 + reach_score[far]
    keep = alive & (new_lo <= new_hi).all(axis=1)
    split = ~shrunk[keep].any(axis=1)
    return new_lo[keep], new_hi[keep], split, score[keep]


def _split_scores(equations, inequalities, rel: np.ndarray) -> np.ndarray:
    """``(B, K)``: each dimension's share of the condition closest to excluding the box
    (largest ``|c| / spread`` for an equation, ``-c / spread`` for an inequality): its
    linear coefficient, plus the remainder shared in proportion to the squared relative
    widths ``rel (B, K)`` (the remainder is quadratic in the half widths)."""
    conditions = [(g, pad, np.abs(g.c)) for g, pad in equations] + [(f, pad, -f.c) for f, pad in inequalities]
    spreads = [af.spread(f) + pad for f, pad, _ in conditions]
    with np.errstate(invalid="ignore"):
        closeness = np.stack([np.nan_to_num(v / s, nan=-np.inf) for (_, _, v), s in zip(conditions, spreads)], axis=1)
    best = np.argmax(closeness, axis=1)
    rows = np.arange(len(best))
    A = np.stack([np.abs(f.A) / s[:, None] for (f, _, _), s in zip(conditions, spreads)], axis=1)[rows, best]
    rho = np.stack([f.rho / s for (f, _, _), s in zip(conditions, spreads)], axis=1)[rows, best]
    share = rel**2 / np.maximum((rel**2).sum(axis=1, keepdims=True), 1e-300)
    return A + rho[:, None] * share
