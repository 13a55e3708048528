"""Compiled point queries of a closed triangle mesh (:class:`~.mesh_arrays.MeshArrays`): the
closest surface point and the signed distance.

The closest point of a triangle is Ericson's (*Real-Time Collision Detection*, 5.1.5); the
tree is searched nearest box first, pruning every box farther than the best so far, so a
query visits ``O(log F)`` triangles when the surface is far from most of them.  The sign
(negative inside) comes from the angle-weighted pseudonormal of the closest feature (face,
edge or vertex), exact for a closed, consistently oriented mesh of one piece, or for a
mesh of several closed pieces (parts glued face to face, which leaves internal double
walls) from the generalised winding number, exact however the pieces touch.  mm.
"""

from __future__ import annotations

import numpy as np

from ..kernels.jit import njit
from .mesh_arrays import STACK_DEPTH

__all__ = ["dot3", "dist_sq", "box_box_sq", "closest_on_triangle", "point_query", "signed_distance_at", "signed_distances"]

@njit(cache=True)
def dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def closest_on_triangle(p, a, b, c, out):
    """Closest point of triangle abc to p into ``out``; returns the feature:
    0 face, 1..3 edge (ab, bc, ca), 4..6 vertex (a, b, c).  Ericson 5.1.5 (scalar code:
    no temporaries)."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        out[0], out[1], out[2] = a[0], a[1], a[2]
        return 4
    bpx, bpy, bpz = p[0] - b[0], p[1] - b[1], p[2] - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        out[0], out[1], out[2] = b[0], b[1], b[2]
        return 5
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        out[0], out[1], out[2] = a[0] + v * abx, a[1] + v * aby, a[2] + v * abz
        return 1
    cpx, cpy, cpz = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        out[0], out[1], out[2] = c[0], c[1], c[2]
        return 6
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        out[0], out[1], out[2] = a[0] + w * acx, a[1] + w * acy, a[2] + w * acz
        return 3
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        out[0], out[1], out[2] = b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2])
        return 2
    denom = 1.0 / (va + vb + vc)
    v, w = vb * denom, vc * denom
    out[0] = a[0] + abx * v + acx * w
    out[1] = a[1] + aby * v + acy * w
    out[2] = a[2] + abz * v + acz * w
    return 0


@njit(cache=True)
def dist_sq(p, q):
    return (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 + (p[2] - q[2]) ** 2


@njit(cache=True)
def _box_point_sq(lo, hi, p):
    d = 0.0
    for k in range(3):
        if p[k] < lo[k]:
            d += (lo[k] - p[k]) ** 2
        elif p[k] > hi[k]:
            d += (p[k] - hi[k]) ** 2
    return d


@njit(cache=True)
def box_box_sq(lo, hi, lo2, hi2):
    d = 0.0
    for k in range(3):
        if hi2[k] < lo[k]:
            d += (lo[k] - hi2[k]) ** 2
        elif lo2[k] > hi[k]:
            d += (lo2[k] - hi[k]) ** 2
    return d


@njit(cache=True)
def point_query(m, p, best_point):
    """Squared distance from p to the mesh, the closest stored face and its feature."""
    return _point_query_within(m, p, best_point, np.inf)


@njit(cache=True)
def _point_query_within(m, p, best_point, bound):
    """As :func:`point_query`, pruning from the start every box farther than ``bound``
    (squared, an upper bound of the answer: the face is -1 when nothing is closer)."""
    best, best_f, best_feat = bound, -1, -1
    q = np.empty(3)
    stack = np.empty(STACK_DEPTH, np.int64)
    stack[0], top = 0, 1
    while top > 0:
        top -= 1
        k = stack[top]
        if _box_point_sq(m.node_lo[k], m.node_hi[k], p) >= best:
            continue
        if m.node_left[k] < 0:
            for f in range(m.node_start[k], m.node_start[k] + m.node_count[k]):
                feat = closest_on_triangle(p, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], q)
                d = dist_sq(p, q)
                if d < best:
                    best, best_f, best_feat = d, f, feat
                    best_point[:] = q
            continue
        l, r = m.node_left[k], m.node_right[k]
        dl = _box_point_sq(m.node_lo[l], m.node_hi[l], p)
        dr = _box_point_sq(m.node_lo[r], m.node_hi[r], p)
        if dl < dr:  # visit the nearer child first: push it last
            stack[top], stack[top + 1] = r, l
        else:
            stack[top], stack[top + 1] = l, r
        top += 2
    return best, best_f, best_feat


@njit(cache=True)
def _pseudonormal(m, f, feat):
    if feat == 0:
        return m.face_normal[f]
    if feat <= 3:
        return m.edge_normal[f, feat - 1]
    return m.vertex_normal[f, feat - 4]


@njit(cache=True)
def _winding_number(m, p):
    """Generalised winding number of the surface around p (1 inside, 0 outside): the sum of
    the triangles' signed solid angles over 4 pi (Van Oosterom & Strackee, 1983)."""
    total = 0.0
    for f in range(m.tri.shape[0]):
        a, b, c = m.tri[f, 0] - p, m.tri[f, 1] - p, m.tri[f, 2] - p
        la, lb, lc = np.sqrt(dot3(a, a)), np.sqrt(dot3(b, b)), np.sqrt(dot3(c, c))
        det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
        den = la * lb * lc + dot3(a, b) * lc + dot3(b, c) * la + dot3(c, a) * lb
        total += 2.0 * np.arctan2(det, den)
    return total / (4.0 * np.pi)


@njit(cache=True)
def signed_distance_at(m, p, q, bound):
    """Signed distance of one point ``p`` (3,) [mm], the closest surface point into ``q``;
    ``bound``: an upper bound of the unsigned distance, which only makes the search faster."""
    d2, f, feat = _point_query_within(m, p, q, bound * bound * (1.0 + 1e-9) + 1e-12)
    if f < 0:  # the bound was not one after all (rounding): search everything
        d2, f, feat = point_query(m, p, q)
    d = np.sqrt(d2)
    inside = _winding_number(m, p) > 0.5 if m.robust_sign else dot3(p - q, _pseudonormal(m, f, feat)) < 0.0
    return -d if inside else d


@njit(cache=True)
def signed_distances(m, points, out_closest):
    """Signed distance of each point (N, 3) to the surface (N,) [mm], negative inside;
    the closest surface points into ``out_closest (N, 3)``.

    The sign is the closest feature's pseudonormal test for a mesh of one connected piece,
    and the winding number (``O(F)`` per point) for a mesh of several pieces, which may
    touch or overlap (parts glued face to face leave internal double walls, where the
    pseudonormal test is wrong)."""
    n = points.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = signed_distance_at(m, points[i], out_closest[i], np.inf)
    return out
