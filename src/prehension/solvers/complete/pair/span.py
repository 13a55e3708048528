"""The span test: the object side alone against the hand's span.

Whether the two contacts' fingertip centres (hand points) are always farther apart on the
object than the hand can ever hold them, whatever the pose: a search of the object
regions' parameters alone (at most four dimensions, no kinematics).
"""

from __future__ import annotations

import heapq
import time

import numpy as np

from ....hands.reach import span_bound_mm
from .forms import object_forms, vector_spread
from .problem import REL_PAD, PairOutcome, PairProblem, halves_widest

__all__ = ["OUT_OF_SPAN_BOXES", "object_distance_range", "object_distance_floor", "best_first_max", "pair_span_mm",
           "span_test", "prove_out_of_span"]  # fmt: skip

#: Box budget of the object-side span test (:func:`prove_out_of_span`) of each pair in
#: :func:`.congruence.congruence_test`, apart from the pair test's own: its boxes cost ~40 us (four
#: dimensions, no kinematics); far from the span it stops after a few, within a tenth of
#: a millimetre of it strongly curved patches need many (guitar-tuning at t* + 4 mm: 91,000
#: boxes, 3.5 s).
OUT_OF_SPAN_BOXES = 100_000


def object_distance_range(pp: PairProblem, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``(B,), (B,)`` [mm] of ``|c_b - c_a|`` over boxes of the pair's box dimensions (only
    the object regions' parameters matter), ``c = o + r nu`` the fingertip centre (or hand
    point) of each side when touching the object.

    With the object side's form ``d = c + sum_k A_k eps_k + B(rho)``, ``s = sum_k |A_k| + rho``
    and ``n = c / |c|``: ``|d| >= n . d >= |c| - sum_k |n . A_k| - rho`` and
    ``|d| >= |c| - s``; ``|d| <= |c| + s``.
    """
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d, _, _ = object_forms(pp, zc, half)
    a = np.linalg.norm(d.c, axis=1)
    s = vector_spread(d)
    n = d.c / np.maximum(a, 1e-300)[:, None]
    projected = a - np.abs(np.einsum("bi,bik->bk", n, d.A)).sum(axis=1) - d.rho
    return np.maximum(np.maximum(a - s, projected), 0.0), a + s


def object_distance_floor(pp: PairProblem, *, tol_mm: float = 0.01, max_boxes: int = 2_000, batch: int = 64,
                          span_mm: float | None = None) -> tuple[float, float, int]:  # fmt: skip
    """``(floor, best, boxes)``: a proven lower bound ``floor`` [mm] of ``|c_b - c_a|`` over
    the object regions' parameters (:func:`object_distance_range`), the smallest distance
    met at a box centre (``best >= `` the true minimum ``>= floor``) and the boxes used.

    Best-first branch and bound over the object dimensions only (at most four,
    :func:`best_first_max`) until ``best - floor <= tol_mm`` or ``max_boxes`` (the floor is
    then looser, never invalid).  Given the hand's span ``span_mm``, a tenth of the gap
    between ``best`` and the span is tolerated as well (a floor far below the span proves
    nothing and prunes little).
    """
    def tol(best: float) -> float:  # best: minus the smallest distance met
        return tol_mm if span_mm is None else max(tol_mm, 0.1 * (span_mm + best))

    bound, best, boxes = best_first_max(pp, lambda lo, hi: -object_distance_range(pp, lo, hi)[0], tol, max_boxes, batch)
    return max(-bound, 0.0) * (1.0 - REL_PAD) - REL_PAD, -best, boxes


def best_first_max(pp: PairProblem, upper_of, tol_of, max_boxes: int, batch: int = 64) -> tuple[float, float, int]:
    """``(bound, best, boxes)`` of the largest value of a function of the object regions'
    parameters: ``upper_of(lo, hi)`` gives upper bounds ``(B,)`` over boxes of the pair's
    full dimensions (only the object dimensions vary; on point boxes, the values).  Best-first:
    the ``batch`` boxes of largest bound are split through their widest relative object
    dimension until ``bound - best <= tol_of(best)`` (``best``: the largest value met at a
    box centre, ``<=`` the true maximum ``<= bound``) or ``max_boxes``: the bound is then
    looser, never invalid.  Boxes whose bound is within the tolerance of ``best`` stay open
    (their bounds still count) without being split."""
    dims = np.arange(pp.slices[1].start, pp.n_dims)
    scale = np.maximum(pp.upper - pp.lower, 1e-12)
    heap: list = []
    best, boxes, counter = -np.inf, 0, 0
    lo, hi = pp.lower[None].copy(), pp.upper[None].copy()
    while True:
        boxes += len(lo)
        upper = upper_of(lo, hi)
        centre = 0.5 * (lo + hi)
        best = max(best, float(upper_of(centre, centre).max()))
        for value, a, b in zip(upper, lo, hi):
            heapq.heappush(heap, (-float(value), counter, a, b))
            counter += 1
        bound, tol = -heap[0][0], tol_of(best)
        if bound - best <= tol or not dims.size or boxes >= max_boxes:
            return bound, best, boxes
        popped = [heapq.heappop(heap) for _ in range(min(batch, len(heap)))]
        take = [t for t in popped if -t[0] > best + tol] or popped[:1]
        for t in popped[len(take):]:  # the others stay open: their bounds still count
            heapq.heappush(heap, t)
        lo, hi = halves_widest(np.array([t[2] for t in take]), np.array([t[3] for t in take]), dims, scale)


def pair_span_mm(pp: PairProblem, hand, *, tight: bool = False) -> float:
    """The proven span [mm] between the pair's two hand points (fingertip centres) over the
    joint limits (:func:`prehension.hands.reach.span_bound_mm`): within 1 mm of the true
    maximum (the bound of the system's reach constraints, remembered per hand), or within
    0.05 mm when ``tight`` (about a second more per pair)."""
    (link_a, point_a), (link_b, point_b) = pp.points
    if tight:
        return span_bound_mm(hand, link_a, point_a, link_b, point_b, tol_mm=0.05, max_boxes=200_000)
    return span_bound_mm(hand, link_a, point_a, link_b, point_b)


def span_test(pp: PairProblem, hand, max_boxes: int) -> tuple[bool, float, bool, int]:
    """``(proved, floor, witness, boxes)`` of the span test (see :func:`prove_out_of_span`): the
    tight span is computed only when the floor comes within 1 mm of the loose one."""
    pad = lambda x: x * (1.0 + REL_PAD) + REL_PAD  # noqa: E731
    span = pad(pair_span_mm(pp, hand))
    floor, best, boxes = object_distance_floor(pp, max_boxes=max_boxes, span_mm=span)
    if span - 1.0 < floor <= span:
        span = min(span, pad(pair_span_mm(pp, hand, tight=True)))
    return floor > span, floor, best <= span, boxes


def prove_out_of_span(pp: PairProblem, hand, *, max_boxes: int = OUT_OF_SPAN_BOXES) -> PairOutcome:
    """Whether the two contacts' fingertip centres (hand points) are always farther apart on
    the object than the hand can ever hold them, whatever the pose: the object side's floor
    (:func:`object_distance_floor`, searched alone: at most four dimensions, where the full
    pair test searches them with every joint angle of both chains) above the hand's span
    (:func:`pair_span_mm`), with a relative margin of 1e-9 for rounding.  Sound for any
    number of contacts: a grasp makes the two distances equal.  ``stopped`` is "witness"
    when a distance met on the object side is within the span.
    """
    started = time.perf_counter()
    proved, _, witness, boxes = span_test(pp, hand, max_boxes)
    return PairOutcome(proved, boxes, time.perf_counter() - started, "" if proved else "witness" if witness else "budget")
