"""Force closure (a linear program) and the Ferrari-Canny epsilon and volume (a convex hull).

Let ``W = {w_1 .. w_K}`` be the primitive wrenches of a grasp (:mod:`.wrenches`).

**Force closure.**  The grasp can resist every external wrench exactly when the ``w_k``
*positively span* ``R^6``, i.e. when the origin lies in the interior of their convex hull.
That holds iff the ``w_k`` span ``R^6`` and some strictly positive combination of them
vanishes, which one linear program decides (solved by HiGHS):

.. math::

    t^* = \\max_{\\lambda, t}\\; t \\quad \\text{s.t.}\\quad \\sum_k \\lambda_k w_k = 0,\\;
    \\sum_k \\lambda_k = 1,\\; \\lambda_k \\ge t \\ge 0;

the grasp is force closure iff ``t* > 0`` (beyond :data:`CLOSURE_TOLERANCE`) and
``rank W = 6``.  The LP (``K + 1`` columns, ``K + 7`` rows, ``K`` of the order of 30) is
solved without HiGHS's presolve, which costs more than it saves at this size (about half
the LP's time, issue 16); ``t*`` then differs from the presolved one by rounding only
(~1e-14 relative, far inside ``prehension check``'s 1e-9).

**Epsilon (Q1) and volume.**  Ferrari & Canny's epsilon is the radius of the largest ball
about the origin inside ``conv W``: the smallest wrench magnitude that the grasp cannot
resist with a total normal force of one, i.e. the distance from the origin to the nearest
facet of the hull (Qhull, through ``scipy.spatial.ConvexHull``).  It is 0 for a grasp that
is not force closure (the LP decides, so that ``epsilon > 0`` exactly when the grasp is
force closure).  The volume is the 6-D volume of the hull (GraspIt!'s second measure);
both are 0 when the wrenches lie in a hyperplane (e.g. every contact on one flat face).
"""

from __future__ import annotations

from dataclasses import dataclass

import highspy
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..lp import quiet_highs

__all__ = ["ClosureTest", "force_closure", "hull_measures", "hull_facets", "CLOSURE_TOLERANCE"]

CLOSURE_TOLERANCE = 1e-9  # smallest LP margin t* (a weight) that counts as force closure
_RANK_TOLERANCE = 1e-9  # relative singular value below which the wrenches lose a dimension


@dataclass(frozen=True)
class ClosureTest:
    """What the force-closure LP found.

    Attributes:
        force_closure: the wrenches positively span ``R^6``.
        margin: ``t*``, the smallest weight of a positive combination that vanishes
            (0 when none exists; at most ``1 / K``).
        rank: the dimension the wrenches span.
    """

    force_closure: bool
    margin: float
    rank: int


def _rank(vectors: np.ndarray) -> int:
    if len(vectors) == 0:
        return 0
    s = np.linalg.svd(vectors, compute_uv=False)
    return int(np.sum(s > _RANK_TOLERANCE * max(float(s[0]), 1e-300)))


def force_closure(wrenches) -> ClosureTest:
    """The force-closure test of ``wrenches (K, 6)`` (see the module docstring)."""
    W = np.asarray(wrenches, dtype=float).reshape(-1, 6)
    rank = _rank(W)
    if rank < 6:
        return ClosureTest(False, 0.0, rank)
    margin = _positive_combination_margin(W)
    return ClosureTest(bool(margin > CLOSURE_TOLERANCE), margin, rank)


def _positive_combination_margin(W: np.ndarray) -> float:
    """``t*`` of the LP in the module docstring (0 when it is infeasible)."""
    K = len(W)
    # rows: W^T lambda = 0 (0..5), sum lambda = 1 (6), lambda_k - t >= 0 (7 + k); columns: lambda (K), t
    # column k of lambda holds W[k] in rows 0..5, 1 in row 6 and 1 in row 7 + k; column t holds -1 in rows 7..
    rows = np.tile(np.r_[np.arange(7), 0], (K, 1)).astype(np.int32)
    rows[:, 7] = 7 + np.arange(K)
    values = np.concatenate([W, np.ones((K, 1)), np.ones((K, 1))], axis=1)  # (K, 8)
    index = np.concatenate([rows.ravel(), 7 + np.arange(K, dtype=np.int32)])
    value = np.concatenate([values.ravel(), -np.ones(K)])
    start = np.r_[np.arange(K + 1) * 8, 8 * K + K].astype(np.int32)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = K + 1, 7 + K
    lp.col_cost_ = np.r_[np.zeros(K), -1.0]  # minimise -t
    lp.col_lower_, lp.col_upper_ = np.zeros(K + 1), np.ones(K + 1)
    lp.row_lower_ = np.r_[np.zeros(6), 1.0, np.zeros(K)]
    lp.row_upper_ = np.r_[np.zeros(6), 1.0, np.full(K, highspy.kHighsInf)]
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = start
    lp.a_matrix_.index_ = index
    lp.a_matrix_.value_ = value
    h = quiet_highs()
    h.setOptionValue("presolve", "off")  # see the module docstring: twice as fast on this tiny LP
    h.passModel(lp)
    h.run()
    if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return 0.0
    return max(float(h.getSolution().col_value[K]), 0.0)


def hull_measures(wrenches) -> tuple[float, float]:
    """``(distance from the origin to the nearest facet, volume)`` of ``conv(wrenches (K, 6))``.

    The distance is negative when the origin lies outside the hull; both are 0 when the
    hull is flat (the wrenches lie in an affine hyperplane).
    """
    hull = _hull(np.asarray(wrenches, dtype=float).reshape(-1, 6))
    if hull is None:
        return 0.0, 0.0
    normals, offsets = _unit_facets(hull)
    return float(np.min(-offsets)), float(hull.volume)


def hull_facets(wrenches) -> tuple[np.ndarray, np.ndarray] | None:
    """``(outward unit normals (F, 6), offsets (F,))`` of the facets of ``conv(wrenches (K, 6))``
    (``a . x + b <= 0`` inside; ``-b`` the signed distance of the origin to each facet plane);
    ``None`` when the hull is flat.  The facets :func:`hull_measures` measures."""
    hull = _hull(np.asarray(wrenches, dtype=float).reshape(-1, 6))
    return None if hull is None else _unit_facets(hull)


def _hull(W: np.ndarray):
    if len(W) < 7 or _rank(W[1:] - W[0]) < 6:
        return None
    try:
        return ConvexHull(W)
    except QhullError:  # flat up to rounding
        return None


def _unit_facets(hull) -> tuple[np.ndarray, np.ndarray]:
    normals, offsets = hull.equations[:, :6], hull.equations[:, 6]  # n . x + b <= 0 inside
    norm = np.linalg.norm(normals, axis=1)
    return normals / norm[:, None], offsets / norm
