"""A smooth grasp measure that tracks the Ferrari-Canny epsilon near a grasp.

Epsilon is the distance from the origin to the nearest facet of the convex hull of the
primitive wrenches ``w_k`` (:mod:`prehension.quality.measures`); with the hull's outward
unit facet normals ``a_f``, it is the smallest *support* of the wrench set over them:

.. math::

    \\varepsilon(W) = \\min_f \\max_k\\, a_f \\cdot w_k \\quad (\\text{at } W),\\qquad
    \\varepsilon(W') \\le \\min_f \\max_k\\, a_f \\cdot w'_k \\quad (\\text{any } W'),

the second because the support of ``conv W'`` in any unit direction bounds the distance
to its nearest facet from above.  Holding the facet normals of the current grasp fixed,
the right-hand side is a polytope with frozen facet directions whose facets follow the
moving wrenches; it equals epsilon at the current grasp.  Its min and max are smoothed
by log-sum-exp at a temperature ``tau`` (a fraction of the current epsilon), so that its
gradient averages over the nearly-nearest facets and each facet's supporting vertices
instead of following one of them (the hard min-max zig-zags between facets):

.. math::

    S_\\tau(W) = -\\tau \\log \\sum_f \\exp\\big(-h_f/\\tau\\big), \\qquad
    h_f = \\tau \\log \\sum_k \\exp\\big(a_f \\cdot w_k / \\tau\\big).

The same expression measures a grasp that is *not* force closure: the facets whose
planes separate the origin from the hull have negative offsets, and raising ``S`` pushes
them past the origin (toward force closure).  A flat hull (every wrench in a
hyperplane) has no facets: no gradient, no ascent.  The surrogate depends on the object
regions' parameters only (where the object is touched); its gradient in them is taken
by forward differences.
"""

from __future__ import annotations

import numpy as np
from ..quality import QualityOptions, primitive_wrenches

__all__ = ["support_surrogate"]


def support_surrogate(points_mm: np.ndarray, inward: np.ndarray, center_mm, radius_mm: float, options: QualityOptions,
                      normals: np.ndarray, tau: float) -> np.ndarray:  # fmt: skip
    """``S_tau`` (module docstring) of ``B`` grasps: ``points_mm, inward (B, C, 3)`` (object
    frame, inward unit normals), facet ``normals (F, 6)``, temperature ``tau > 0`` -> (B,)."""
    B, C = points_mm.shape[:2]
    W = primitive_wrenches(points_mm.reshape(-1, 3), inward.reshape(-1, 3), center_mm, radius_mm, options)  # (B C, G, 6)
    s = np.einsum("fj,bkj->bfk", normals, W.reshape(B, -1, 6))  # (B, F, K): support of each wrench along each facet normal
    top = s.max(axis=2, keepdims=True)
    h = top[..., 0] + tau * np.log(np.exp((s - top) / tau).sum(axis=2))  # (B, F): soft max over k
    low = h.min(axis=1, keepdims=True)
    return low[:, 0] - tau * np.log(np.exp(-(h - low) / tau).sum(axis=1))  # (B,): soft min over f
