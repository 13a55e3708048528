"""Exact distances to a closed triangle mesh: points (signed) and segments (unsigned).

:class:`MeshDistance` holds a bounding-volume hierarchy (axis-aligned boxes, median split)
over the triangles of a closed, outward-oriented mesh, as flat arrays that numba's
kernels read (:class:`MeshArrays`).  Distances are exact up to rounding, not sampled:

* :meth:`MeshDistance.signed_distance`: the distance from each point to the surface,
  negative inside.  The sign comes from the angle-weighted pseudonormal of the closest
  feature (face, edge or vertex), which is exact for a closed, consistently oriented
  mesh of one piece (Bærentzen & Aanæs, IEEE TVCG 11(3), 2005); for a mesh of several
  closed pieces (parts glued face to face, which leaves internal double walls) from the
  generalised winding number, exact for any closed pieces however they touch.
* :meth:`MeshDistance.segment_distance`: the distance from each segment to the surface
  (0 when the segment crosses it), the minimum over triangles of the closed-form
  segment-triangle distance (Ericson, *Real-Time Collision Detection*, 5.1.5 and 5.1.9);
  :func:`segment_closest` (:meth:`MeshDistance.closest_pair`) also returns the closest
  pair (a point of the segment, a point of the surface), for the local solver's
  penetration rows.

Both prune with a lower bound per box, so a query visits ``O(log F)`` triangles when the
surface is far from most of them.  All lengths are in the mesh's units (mm in prehension).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._compiled import aot

try:  # numba is a dependency; without it the same code runs as (slow) Python
    from numba import njit
except ImportError:  # pragma: no cover

    def njit(*args, **kwargs):
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f


__all__ = [
    "MeshArrays", "MeshDistance", "SdGrid", "build_mesh_arrays", "empty_mesh_arrays", "empty_sd_grid", "grid_segment_min_sd", "in_grid", "new_sd_grid",
    "segment_closest", "segment_closest_within", "segment_min_sd",
]  # fmt: skip

LEAF_SIZE = 8
_STACK = 128  # traversal stack depth: enough for trees of up to 2^60 leaves


class MeshArrays(NamedTuple):
    """The flat arrays every distance kernel reads (a numba-friendly bundle).

    Triangles are stored in tree order, so that leaf ``k`` holds the triangles
    ``node_start[k] : node_start[k] + node_count[k]``.

    Attributes:
        tri: (F, 3, 3) triangle corners [mm], ``tri[f, i]`` the i-th corner.
        face_normal: (F, 3) unit outward face normals.
        edge_normal: (F, 3, 3) pseudonormal of edge ``i`` (corners ``i`` and ``i + 1``):
            the normalised sum of the normals of the two faces that share it.
        vertex_normal: (F, 3, 3) angle-weighted pseudonormal of corner ``i``.
        node_lo, node_hi: (N, 3) box corners of each tree node [mm].
        node_left, node_right: (N,) children (-1 for a leaf).
        node_start, node_count: (N,) a leaf's triangle range.
        face_id: (F,) index of each stored triangle in the original mesh.
        robust_sign: inside/outside by the winding number (a mesh of several pieces)
            instead of the pseudonormal test.
    """

    tri: np.ndarray
    face_normal: np.ndarray
    edge_normal: np.ndarray
    vertex_normal: np.ndarray
    node_lo: np.ndarray
    node_hi: np.ndarray
    node_left: np.ndarray
    node_right: np.ndarray
    node_start: np.ndarray
    node_count: np.ndarray
    face_id: np.ndarray
    robust_sign: bool


# -- building ---------------------------------------------------------------------------
def _unit_rows(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _pseudonormals(vertices: np.ndarray, faces: np.ndarray):
    """Face normals (F, 3), edge pseudonormals (F, 3, 3), vertex pseudonormals (F, 3, 3)."""
    tri = vertices[faces]  # (F, 3, 3)
    n_face = _unit_rows(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    # vertex: sum over faces of (incident angle) * face normal
    angles = np.empty(faces.shape)
    for i in range(3):
        e1 = _unit_rows(tri[:, (i + 1) % 3] - tri[:, i])
        e2 = _unit_rows(tri[:, (i + 2) % 3] - tri[:, i])
        angles[:, i] = np.arccos(np.clip(np.sum(e1 * e2, axis=1), -1.0, 1.0))
    acc = np.zeros_like(vertices)
    for i in range(3):
        np.add.at(acc, faces[:, i], angles[:, i, None] * n_face)
    n_vertex = _unit_rows(acc)[faces]  # (F, 3, 3)
    # edge i = (corner i, corner i+1): the sum of the normals of the faces sharing it
    a, b = faces, np.roll(faces, -1, axis=1)
    key = np.minimum(a, b).astype(np.int64) * (len(vertices) + 1) + np.maximum(a, b)  # (F, 3)
    _, inverse = np.unique(key.ravel(), return_inverse=True)
    edge_sum = np.zeros((inverse.max() + 1, 3))
    np.add.at(edge_sum, inverse, np.repeat(n_face, 3, axis=0))
    n_edge = _unit_rows(edge_sum[inverse]).reshape(-1, 3, 3)
    return n_face, n_edge, n_vertex


def _build_tree(centroids: np.ndarray, lo_f: np.ndarray, hi_f: np.ndarray):
    """Median-split tree over faces: node arrays and the face order (leaves contiguous)."""
    order = np.arange(len(centroids))
    nodes = []  # [lo, hi, left, right, start, count]
    todo = [(0, len(order), -1, 0)]  # (start, end, parent, side)
    while todo:
        s, e, parent, side = todo.pop()
        idx = order[s:e]
        k = len(nodes)
        nodes.append([lo_f[idx].min(axis=0), hi_f[idx].max(axis=0), -1, -1, s, e - s])
        if parent >= 0:
            nodes[parent][2 + side] = k
        if e - s <= LEAF_SIZE:
            continue
        c = centroids[idx]
        axis = int(np.argmax(np.ptp(c, axis=0)))
        order[s:e] = idx[np.argsort(c[:, axis], kind="stable")]
        m = (s + e) // 2
        nodes[k][4], nodes[k][5] = s, 0
        todo += [(m, e, k, 1), (s, m, k, 0)]
    arr = lambda j, dt=float: np.array([n[j] for n in nodes], dtype=dt)  # noqa: E731
    return arr(0), arr(1), arr(2, np.int64), arr(3, np.int64), arr(4, np.int64), arr(5, np.int64), order


def _pieces(n_vertices: int, faces: np.ndarray) -> int:
    """Number of connected pieces of a mesh (faces joined through shared vertices)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(np.arange(len(faces)), 3)
    graph = sp.coo_matrix((np.ones(rows.size), (rows, faces.ravel())), shape=(len(faces), n_vertices)).tocsr()
    used = np.unique(faces)
    n, _ = connected_components((graph.T @ graph)[used][:, used], directed=False)
    return int(n)


def build_mesh_arrays(vertices, faces) -> MeshArrays:
    """The :class:`MeshArrays` of a closed, outward-oriented mesh ``vertices (V, 3)`` [mm], ``faces (F, 3)``."""
    v = np.ascontiguousarray(vertices, dtype=float)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    robust = _pieces(len(v), f) > 1
    n_face, n_edge, n_vertex = _pseudonormals(v, f)
    tri = v[f]
    lo, hi, left, right, start, count, order = _build_tree(tri.mean(axis=1), tri.min(axis=1), tri.max(axis=1))
    c = np.ascontiguousarray
    return MeshArrays(
        c(tri[order]), c(n_face[order]), c(n_edge[order]), c(n_vertex[order]),
        lo, hi, left, right, start, count, order.astype(np.int64), bool(robust),
    )  # fmt: skip


def empty_mesh_arrays() -> MeshArrays:
    """A :class:`MeshArrays` with no triangle (the same numba type as any other): what a
    compiled caller receives when there is no solid; it must not be queried."""
    z = lambda *shape: np.zeros(shape)  # noqa: E731
    i = lambda: np.zeros(0, dtype=np.int64)  # noqa: E731
    return MeshArrays(z(0, 3, 3), z(0, 3), z(0, 3, 3), z(0, 3, 3), z(0, 3), z(0, 3), i(), i(), i(), i(), i(), False)


# -- kernels ----------------------------------------------------------------------------
@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _closest_on_triangle(p, a, b, c, out):
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
def _dist_sq(p, q):
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
def _box_box_sq(lo, hi, lo2, hi2):
    d = 0.0
    for k in range(3):
        if hi2[k] < lo[k]:
            d += (lo[k] - hi2[k]) ** 2
        elif lo2[k] > hi[k]:
            d += (lo2[k] - hi[k]) ** 2
    return d


@njit(cache=True)
def _point_query(m, p, best_point):
    """Squared distance from p to the mesh, the closest stored face and its feature."""
    return _point_query_within(m, p, best_point, np.inf)


@njit(cache=True)
def _point_query_within(m, p, best_point, bound):
    """As :func:`_point_query`, pruning from the start every box farther than ``bound``
    (squared, an upper bound of the answer: the face is -1 when nothing is closer)."""
    best, best_f, best_feat = bound, -1, -1
    q = np.empty(3)
    stack = np.empty(_STACK, np.int64)
    stack[0], top = 0, 1
    while top > 0:
        top -= 1
        k = stack[top]
        if _box_point_sq(m.node_lo[k], m.node_hi[k], p) >= best:
            continue
        if m.node_left[k] < 0:
            for f in range(m.node_start[k], m.node_start[k] + m.node_count[k]):
                feat = _closest_on_triangle(p, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], q)
                d = _dist_sq(p, q)
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
        la, lb, lc = np.sqrt(_dot(a, a)), np.sqrt(_dot(b, b)), np.sqrt(_dot(c, c))
        det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
        den = la * lb * lc + _dot(a, b) * lc + _dot(b, c) * la + _dot(c, a) * lb
        total += 2.0 * np.arctan2(det, den)
    return total / (4.0 * np.pi)


@njit(cache=True)
def _signed_distance(m, p, q, bound):
    """Signed distance of one point ``p`` (3,) [mm], the closest surface point into ``q``;
    ``bound``: an upper bound of the unsigned distance, which only makes the search faster."""
    d2, f, feat = _point_query_within(m, p, q, bound * bound * (1.0 + 1e-9) + 1e-12)
    if f < 0:  # the bound was not one after all (rounding): search everything
        d2, f, feat = _point_query(m, p, q)
    d = np.sqrt(d2)
    inside = _winding_number(m, p) > 0.5 if m.robust_sign else _dot(p - q, _pseudonormal(m, f, feat)) < 0.0
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
        out[i] = _signed_distance(m, points[i], out_closest[i], np.inf)
    return out


@njit(cache=True)
def _box_segment_sq(lo, hi, p0, p1, seg_lo, seg_hi):
    """A lower bound of the squared distance from box ``lo``-``hi`` to segment ``p0``-``p1``
    (whose own box is ``seg_lo``-``seg_hi``): the larger of the two boxes' distance and the
    distance from the box's centre to the segment less the box's half diagonal (its
    bounding sphere), made smaller by 1e-9 mm so that rounding never makes it exceed the
    true distance.  The sphere's bound is the tight one for a long segment across the
    mesh, whose own box holds many boxes that the segment passes far from."""
    d_box = _box_box_sq(lo, hi, seg_lo, seg_hi)
    dx, dy, dz = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    cx, cy, cz = 0.5 * (lo[0] + hi[0]) - p0[0], 0.5 * (lo[1] + hi[1]) - p0[1], 0.5 * (lo[2] + hi[2]) - p0[2]
    dd = dx * dx + dy * dy + dz * dz
    u = min(max((cx * dx + cy * dy + cz * dz) / dd, 0.0), 1.0) if dd > 0.0 else 0.0
    ex, ey, ez = cx - u * dx, cy - u * dy, cz - u * dz
    half = 0.5 * np.sqrt((hi[0] - lo[0]) ** 2 + (hi[1] - lo[1]) ** 2 + (hi[2] - lo[2]) ** 2)
    gap = np.sqrt(ex * ex + ey * ey + ez * ez) - half - 1e-9
    return max(d_box, gap * gap) if gap > 0.0 else d_box


@njit(cache=True)
def _triangle_beyond(p0, p1, a, b, c, best):
    """Whether triangle ``abc`` is at least ``sqrt(best)`` from segment ``p0``-``p1`` by its
    bounding sphere (centroid, farthest corner): a lower bound of the true distance less
    1e-9 mm, so that a triangle skipped by it could not have been closer than ``best``."""
    cx, cy, cz = (a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0, (a[2] + b[2] + c[2]) / 3.0
    r2 = max((a[0] - cx) ** 2 + (a[1] - cy) ** 2 + (a[2] - cz) ** 2, (b[0] - cx) ** 2 + (b[1] - cy) ** 2 + (b[2] - cz) ** 2,
             (c[0] - cx) ** 2 + (c[1] - cy) ** 2 + (c[2] - cz) ** 2)  # fmt: skip
    dx, dy, dz = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    ex, ey, ez = cx - p0[0], cy - p0[1], cz - p0[2]
    dd = dx * dx + dy * dy + dz * dz
    u = min(max((ex * dx + ey * dy + ez * dz) / dd, 0.0), 1.0) if dd > 0.0 else 0.0
    ex, ey, ez = ex - u * dx, ey - u * dy, ez - u * dz
    gap = np.sqrt(ex * ex + ey * ey + ez * ez) - np.sqrt(r2) - 1e-9
    return gap > 0.0 and gap * gap >= best


@njit(cache=True)
def _seg_seg_st(p0, p1, q0, q1):
    """Closest points of segments p0p1 and q0q1 (Ericson 5.1.9, scalar code):
    ``(squared distance, s, t)`` with the points ``p0 + s (p1 - p0)`` and ``q0 + t (q1 - q0)``."""
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-18
    if a <= eps and e <= eps:
        return rx * rx + ry * ry + rz * rz, 0.0, 0.0
    if a <= eps:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= eps:
            t, s = 0.0, min(max(-c / a, 0.0), 1.0)
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > eps * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
    wx = rx + d1x * s - d2x * t
    wy = ry + d1y * s - d2y * t
    wz = rz + d1z * s - d2z * t
    return wx * wx + wy * wy + wz * wz, s, t


@njit(cache=True)
def _seg_seg_sq(p0, p1, q0, q1):
    """Squared distance between segments p0p1 and q0q1."""
    return _seg_seg_st(p0, p1, q0, q1)[0]


@njit(cache=True)
def _segment_crosses(p0, p1, a, b, c):
    """Whether segment p0p1 meets triangle abc (signed volumes, closed triangle; scalar code)."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    s0 = (p0[0] - a[0]) * nx + (p0[1] - a[1]) * ny + (p0[2] - a[2]) * nz
    s1 = (p1[0] - a[0]) * nx + (p1[1] - a[1]) * ny + (p1[2] - a[2]) * nz
    if (s0 > 0.0 and s1 > 0.0) or (s0 < 0.0 and s1 < 0.0) or s0 == s1:
        return False
    k = s0 / (s0 - s1)
    x0, x1, x2 = p0[0] + k * (p1[0] - p0[0]), p0[1] + k * (p1[1] - p0[1]), p0[2] + k * (p1[2] - p0[2])
    for i in range(3):
        A = a if i == 0 else (b if i == 1 else c)
        B = b if i == 0 else (c if i == 1 else a)
        ex, ey, ez = B[0] - A[0], B[1] - A[1], B[2] - A[2]
        wx, wy, wz = x0 - A[0], x1 - A[1], x2 - A[2]
        if (ey * wz - ez * wy) * nx + (ez * wx - ex * wz) * ny + (ex * wy - ey * wx) * nz < 0.0:
            return False
    return True


@njit(cache=True)
def _segment_triangle_sq(p0, p1, a, b, c, q):
    if _segment_crosses(p0, p1, a, b, c):
        return 0.0
    _closest_on_triangle(p0, a, b, c, q)
    best = _dist_sq(p0, q)
    _closest_on_triangle(p1, a, b, c, q)
    best = min(best, _dist_sq(p1, q))
    best = min(best, _seg_seg_sq(p0, p1, a, b))
    best = min(best, _seg_seg_sq(p0, p1, b, c))
    return min(best, _seg_seg_sq(p0, p1, c, a))


@njit(cache=True)
def _segment_query(m, p0, p1):
    """Squared distance from segment ``p0``-``p1`` to the surface (0 when it crosses it)."""
    return _segment_query_within(m, p0, p1, np.inf)


@njit(cache=True)
def _segment_query_within(m, p0, p1, bound):
    """As :func:`_segment_query`, pruning from the start every box farther than ``bound``
    (squared): the squared distance when it is below ``bound``, else ``bound``.  Below the
    bound, the same value as the unbounded search (the same triangles' minimum)."""
    lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
    best = bound
    q = np.empty(3)
    stack = np.empty(_STACK, np.int64)
    stack[0], top = 0, 1
    while top > 0 and best > 0.0:
        top -= 1
        k = stack[top]
        if _box_segment_sq(m.node_lo[k], m.node_hi[k], p0, p1, lo, hi) >= best:
            continue
        if m.node_left[k] < 0:
            for f in range(m.node_start[k], m.node_start[k] + m.node_count[k]):
                if not _triangle_beyond(p0, p1, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], best):
                    best = min(best, _segment_triangle_sq(p0, p1, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], q))
            continue
        l, r = m.node_left[k], m.node_right[k]
        if _box_box_sq(m.node_lo[l], m.node_hi[l], lo, hi) < _box_box_sq(m.node_lo[r], m.node_hi[r], lo, hi):
            stack[top], stack[top + 1] = r, l  # the nearer child is visited first
        else:
            stack[top], stack[top + 1] = l, r
        top += 2
    return best


@njit(cache=True)
def _lerp(p0, p1, s, out):
    for i in range(3):
        out[i] = p0[i] + s * (p1[i] - p0[i])


@njit(cache=True)
def _segment_triangle_pair(p0, p1, a, b, c, q, ps, pm):
    """Squared distance of segment p0p1 to triangle abc, 0 when they meet; otherwise a
    closest pair, ``ps`` on the segment and ``pm`` on the triangle (left as they are when 0)."""
    if _segment_crosses(p0, p1, a, b, c):
        return 0.0
    _closest_on_triangle(p0, a, b, c, pm)
    best = _dist_sq(p0, pm)
    ps[0], ps[1], ps[2] = p0[0], p0[1], p0[2]
    _closest_on_triangle(p1, a, b, c, q)
    d = _dist_sq(p1, q)
    if d < best:
        best = d
        ps[0], ps[1], ps[2] = p1[0], p1[1], p1[2]
        pm[0], pm[1], pm[2] = q[0], q[1], q[2]
    for i in range(3):
        A = a if i == 0 else (b if i == 1 else c)
        B = b if i == 0 else (c if i == 1 else a)
        d, s, t = _seg_seg_st(p0, p1, A, B)
        if d < best:
            best = d
            _lerp(p0, p1, s, ps)
            _lerp(A, B, t, pm)
    return best


@njit(cache=True)
def segment_closest(m, p0, p1, ps, pm):
    """Distance from segment ``p0``-``p1`` (3,) to the surface [mm], 0 when it crosses the
    surface; otherwise the closest pair: ``ps`` (3,) on the segment, ``pm`` (3,) on the
    surface (the same traversal as :func:`segment_distances`)."""
    return segment_closest_within(m, p0, p1, ps, pm, np.inf)


@njit(cache=True)
def segment_closest_within(m, p0, p1, ps, pm, bound):
    """As :func:`segment_closest` for a segment closer than ``bound`` [mm]; a farther one
    gives ``bound`` (and no pair) after visiting only the boxes within ``bound``."""
    lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
    best = bound * bound
    q, s_t, m_t = np.empty(3), np.empty(3), np.empty(3)
    stack = np.empty(_STACK, np.int64)
    stack[0], top = 0, 1
    while top > 0 and best > 0.0:
        top -= 1
        k = stack[top]
        if _box_segment_sq(m.node_lo[k], m.node_hi[k], p0, p1, lo, hi) >= best:
            continue
        if m.node_left[k] < 0:
            for f in range(m.node_start[k], m.node_start[k] + m.node_count[k]):
                if _triangle_beyond(p0, p1, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], best):
                    continue  # its bounding sphere is no closer than the best so far
                d = _segment_triangle_pair(p0, p1, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], q, s_t, m_t)
                if d < best:
                    best = d
                    ps[:] = s_t
                    pm[:] = m_t
            continue
        l, r = m.node_left[k], m.node_right[k]
        if _box_box_sq(m.node_lo[l], m.node_hi[l], lo, hi) < _box_box_sq(m.node_lo[r], m.node_hi[r], lo, hi):
            stack[top], stack[top + 1] = r, l
        else:
            stack[top], stack[top + 1] = l, r
        top += 2
    return np.sqrt(best)


@njit(cache=True)
def segment_distances(m, starts, ends):
    """Distance from each segment ``starts[i]``-``ends[i]`` (N, 3) to the surface (N,) [mm]."""
    out = np.empty(starts.shape[0])
    for i in range(starts.shape[0]):
        out[i] = np.sqrt(_segment_query(m, starts[i], ends[i]))
    return out


_COARSE = 32  # the first samples at most 32 steps apart (8 mm); intervals are then bisected where needed
REL_TOL = 0.125  # the kernel's rows: beyond step / 2, a tolerance of 1/8 of how far below the surface


@njit(cache=True)
def _sampled_min_sd(m, p0, p1, step, pair, rel):
    """The smallest signed distance over segment ``p0``-``p1`` (3,) [mm], to within
    ``max(step / 2, rel * depth)`` (``depth = -min sd`` below the surface): a value
    ``v`` of ``sd`` at a point of the segment (that point and its closest surface point in
    ``pair (2, 3)``) with ``min sd <= v <= min sd + max(step / 2, rel * max(0, -v))``.
    The residual function passes ``rel = 0`` (within ``step / 2``: its depths may read at
    most ``step / 2`` low, which the complete solver's prune relies on); the local
    kernel's rows :data:`REL_TOL`.

    ``sd`` is 1-Lipschitz along the segment, so on an interval of length ``l`` between two
    measured values ``va``, ``vb`` it is at least ``(va + vb - l) / 2``.  Samples at most
    ``_COARSE * step`` apart first; then an interval is bisected (depth first) only while
    that bound is more than the tolerance below the best value so far; an interval no
    longer than ``step`` never is (its bound is within ``step / 2`` of its ends).  So a
    segment that dips into the surface is measured where it could be deepest, not every
    ``step`` along it; each search starts from the bound the nearer measured end gives
    (``|sd|`` is 1-Lipschitz too).  The tolerance that grows with the depth bounds the work
    on a segment deep inside and parallel to the surface (where ``sd`` is flat and no
    bound prunes): a link 20 mm inside is 20 mm inside to within 2.5 mm, which is all that
    the kernel's rows need."""
    length = np.sqrt((p1[0] - p0[0]) ** 2 + (p1[1] - p0[1]) ** 2 + (p1[2] - p0[2]) ** 2)
    n = max(int(np.ceil(length / (_COARSE * step))), 1)
    todo = np.empty((n + 64, 4))  # (t0, t1, sd(t0), sd(t1)); depth first: n + levels of bisection
    p, q = np.empty(3), np.empty(3)
    best, top, v_prev = np.inf, 0, 0.0
    for i in range(n + 1):
        t = i / n
        _lerp(p0, p1, t, p)
        v = _signed_distance(m, p, q, abs(v_prev) + length / n if i > 0 else np.inf)
        if v < best:
            best = v
            pair[0] = p
            pair[1] = q
        if i > 0:
            todo[top, 0], todo[top, 1], todo[top, 2], todo[top, 3] = (i - 1) / n, t, v_prev, v
            top += 1
        v_prev = v
    slack = 1e-9 * (1.0 + length)
    while top > 0:
        top -= 1
        ta, tb, va, vb = todo[top, 0], todo[top, 1], todo[top, 2], todo[top, 3]
        span = (tb - ta) * length
        tol = max(0.5 * step, -rel * best)
        if span <= step or 0.5 * (va + vb - span) + tol + slack >= best or top + 2 > todo.shape[0]:
            continue  # cannot be lower than the best by more than the tolerance
        tm = 0.5 * (ta + tb)
        _lerp(p0, p1, tm, p)
        vm = _signed_distance(m, p, q, min(abs(va), abs(vb)) + 0.5 * span)
        if vm < best:
            best = vm
            pair[0] = p
            pair[1] = q
        todo[top, 0], todo[top, 1], todo[top, 2], todo[top, 3] = ta, tm, va, vm
        todo[top + 1, 0], todo[top + 1, 1], todo[top + 1, 2], todo[top + 1, 3] = tm, tb, vm, vb
        top += 2
    return best


@njit(cache=True)
def segment_min_sd(m, p0, p1, step, pair, bound, rel):
    """The smallest signed distance over segment ``p0``-``p1`` (3,) to the surface [mm], and
    where: ``pair[0]`` on the segment, ``pair[1]`` the closest surface point (2, 3); for a
    segment outside the surface and farther than ``bound`` [mm], ``bound`` (and no pair):
    the search then visits only the boxes within ``bound``.

    Exact (the closed-form segment distance) for a segment wholly outside; for a segment
    that meets the surface or lies inside, the sampled minimum of :func:`_sampled_min_sd`
    (within ``max(step / 2, rel * depth)`` of the true value, from above), and at most
    0 (such a segment has a point on or inside the surface, which the samples may miss)."""
    d = segment_closest_within(m, p0, p1, pair[0], pair[1], bound)
    near = d + np.sqrt(_dist_sq(p0, pair[0])) if d < bound else np.inf  # p0 is no farther
    if _wholly_outside(m, p0, d, near):  # exact (or the bound)
        return d
    return min(_sampled_min_sd(m, p0, p1, step, pair, rel), 0.0)


@njit(cache=True)
def _wholly_outside(m, p0, d, near):
    """Whether a segment from ``p0`` at distance ``d`` from the surface lies wholly outside;
    ``near``: an upper bound of ``p0``'s distance to the surface (``inf`` if none is known),
    which only makes the search faster.

    A segment that does not meet the surface (``d > 0``) lies wholly on one side, the side
    of ``p0``: outside when ``p0`` is outside the bounding box of the whole mesh (no point
    there is inside; the common case of a finger away from the object, and what spares the
    full signed-distance query, an ``O(F)`` winding number on a mesh of several pieces),
    else by the sign of its signed distance."""
    if not d > 0.0:
        return False
    if _outside_root_box(m, p0):
        return True
    q = np.empty(3)
    return _signed_distance(m, p0, q, near) > 0.0


@njit(cache=True)
def _outside_root_box(m, p):
    """Whether ``p`` (3,) lies strictly outside the box of the tree's root (node 0, which
    holds every triangle): no point outside it is inside the closed surface."""
    for k in range(3):
        if p[k] < m.node_lo[0, k] or p[k] > m.node_hi[0, k]:
            return True
    return False


@njit(cache=True)
def capsule_depths(m, starts, ends, radius, step, cap):
    """Penetration depth of capsules (segments ``starts``-``ends`` (N, 3), ``radius`` (N,)),
    (N,) [mm]: ``max(0, r - min sd)`` over the segment (:func:`segment_min_sd`: exact for
    a segment outside the surface; for one reaching in, sampled, within ``step / 2`` of
    the true depth, from below).

    ``cap`` [mm] (``inf`` for every depth): where a depth is known to exceed ``cap`` without
    sampling, a lower bound above ``cap`` is returned instead of the depth (a segment that
    touches or enters the surface is at least ``r`` deep, one wholly inside ``r + d``).  So
    every value at most ``cap`` is the depth, and a value above ``cap`` means a depth above it:
    what a yes/no test against ``cap`` needs, without the samples."""
    n = starts.shape[0]
    out = np.zeros(n)
    pair = np.empty((2, 3))
    for i in range(n):
        # searched only up to the radius: a segment outside and at least ``r`` away is 0 deep
        reach = radius[i] * (1.0 + 1e-9) + 1e-9
        d = np.sqrt(_segment_query_within(m, starts[i], ends[i], reach * reach))
        near = d + np.sqrt(_dist_sq(starts[i], ends[i])) if d < reach else np.inf  # starts[i] no farther
        if _wholly_outside(m, starts[i], d, near):  # exact (0 beyond the reach)
            out[i] = max(0.0, radius[i] - d) if d < reach else 0.0
        elif radius[i] + d > cap:  # touching or inside: at least r (+ d when wholly inside)
            out[i] = radius[i] + d
        else:  # as segment_min_sd, without its closest pair
            out[i] = radius[i] - min(_sampled_min_sd(m, starts[i], ends[i], step, pair, 0.0), 0.0)
    return out


# -- a lazily filled grid of the signed distance (the local kernel's seeing rows) ------------
GRID_PAD_MM = 20.0  # the grid covers the mesh's box grown by this much on every side
# Finest spacing.  Measured (2026-11-23, builtin tasks x8 in one batch, and the 39 tasks of
# benchmarks/objects.py): 4-6 mm steer the seeing runs as well as 2 mm (same statuses on all
# 39 tasks) at a third of the node fills; mean solve 5.7 ms at 2, 7.1 at 3 (one task's
# seeing runs went astray), 4.0 at 4, 3.8 at 5, 4.5 at 6, 11.7 at 8 mm: 5 mm, in the middle
# of the good range.
GRID_MIN_H_MM = 5.0
GRID_MAX_NODES = 2_000_000  # coarser than GRID_MIN_H_MM when the box would need more (8 MB of float32)


class SdGrid(NamedTuple):
    """The mesh's signed distance at the nodes of a regular grid, each node computed
    (exactly, :func:`_signed_distance`) the first time it is read and kept: an approximate,
    cheap signed distance (trilinear, error up to about the spacing near edges and corners)
    for the local kernel's *seeing* rows, which only steer the iterations; every verdict
    still comes from the exact queries.  A node's value depends only on the mesh, so the
    order in which nodes are filled changes no answer.

    Attributes:
        lo: (3,) position of node (0, 0, 0), object frame [mm].
        h: spacing [mm].
        val: (nx, ny, nz) float32 signed distance at node ``lo + h (i, j, k)`` [mm], NaN until read.
    """

    lo: np.ndarray
    h: float
    val: np.ndarray


def new_sd_grid(m: MeshArrays) -> SdGrid:
    """An unfilled :class:`SdGrid` over ``m``'s box grown by :data:`GRID_PAD_MM`, spacing
    :data:`GRID_MIN_H_MM` or coarser so that it has at most about :data:`GRID_MAX_NODES` nodes."""
    if m.tri.shape[0] == 0:
        return empty_sd_grid()
    lo, hi = m.node_lo[0] - GRID_PAD_MM, m.node_hi[0] + GRID_PAD_MM
    ext = hi - lo
    h = max(GRID_MIN_H_MM, float(np.cbrt(np.prod(ext) / GRID_MAX_NODES)))
    n = np.ceil(ext / h).astype(np.int64) + 1
    return SdGrid(np.ascontiguousarray(lo, dtype=float), float(h), np.full(tuple(int(k) for k in n), np.nan, dtype=np.float32))


def empty_sd_grid() -> SdGrid:
    """A grid with no node (the same numba type): every point lies outside it."""
    return SdGrid(np.zeros(3), 1.0, np.full((1, 1, 1), np.nan, dtype=np.float32))


@njit(cache=True)
def _fill_node(m, g, i, j, k):
    """Compute node ``(i, j, k)`` of the grid (its first read)."""
    p, q = np.empty(3), np.empty(3)
    p[0], p[1], p[2] = g.lo[0] + i * g.h, g.lo[1] + j * g.h, g.lo[2] + k * g.h
    g.val[i, j, k] = _signed_distance(m, p, q, np.inf)


@njit(cache=True)
def in_grid(g, p):
    """Whether ``p`` (3,) lies in the grid's box (a cell of it holds it)."""
    for a in range(3):
        u = (p[a] - g.lo[a]) / g.h
        if not (0.0 <= u <= g.val.shape[a] - 1):
            return False
    return True


@njit(cache=True)
def _fill_cell(m, g, i, j, k):
    """Compute the nodes of cell ``(i, j, k)`` not computed yet (their first read)."""
    for n in range(8):
        a, b, e = i + (n & 1), j + ((n >> 1) & 1), k + (n >> 2)
        if g.val[a, b, e] != g.val[a, b, e]:  # NaN
            _fill_node(m, g, a, b, e)


@njit(cache=True)
def grid_sd(m, g, p, grad):
    """Trilinear signed distance at ``p`` (3,) inside the grid (:func:`in_grid`) [mm], its
    gradient into ``grad`` (3,) (the cell's, unnormalised); the cell's nodes computed on
    their first read."""
    val, h, lo = g.val, g.h, g.lo
    u, v, w = (p[0] - lo[0]) / h, (p[1] - lo[1]) / h, (p[2] - lo[2]) / h
    i = min(max(int(np.floor(u)), 0), val.shape[0] - 2)
    j = min(max(int(np.floor(v)), 0), val.shape[1] - 2)
    k = min(max(int(np.floor(w)), 0), val.shape[2] - 2)
    x, y, z = u - i, v - j, w - k
    c000, c100, c010, c110 = val[i, j, k], val[i + 1, j, k], val[i, j + 1, k], val[i + 1, j + 1, k]
    c001, c101, c011, c111 = val[i, j, k + 1], val[i + 1, j, k + 1], val[i, j + 1, k + 1], val[i + 1, j + 1, k + 1]
    total = c000 + c100 + c010 + c110 + c001 + c101 + c011 + c111
    if total != total:  # a node not computed yet
        _fill_cell(m, g, i, j, k)
        c000, c100, c010, c110 = val[i, j, k], val[i + 1, j, k], val[i, j + 1, k], val[i + 1, j + 1, k]
        c001, c101, c011, c111 = val[i, j, k + 1], val[i + 1, j, k + 1], val[i, j + 1, k + 1], val[i + 1, j + 1, k + 1]
    c00, c01 = c000 * (1 - x) + c100 * x, c001 * (1 - x) + c101 * x
    c10, c11 = c010 * (1 - x) + c110 * x, c011 * (1 - x) + c111 * x
    c0, c1 = c00 * (1 - y) + c10 * y, c01 * (1 - y) + c11 * y
    dx0 = (c100 - c000) * (1 - y) + (c110 - c010) * y
    dx1 = (c101 - c001) * (1 - y) + (c111 - c011) * y
    grad[0] = (dx0 * (1 - z) + dx1 * z) / h
    grad[1] = ((c10 - c00) * (1 - z) + (c11 - c01) * z) / h
    grad[2] = (c1 - c0) / h
    return c0 * (1 - z) + c1 * z


@njit(cache=True)
def grid_segment_min_sd(m, g, p0, p1, pair):
    """The smallest trilinear signed distance (:func:`grid_sd`) over samples at most half
    a spacing apart along segment ``p0``-``p1`` (both in the grid) [mm], and where:
    ``pair[0]`` the sample, ``pair[1]`` the surface point its value and gradient point at
    (``pair[0] - v n``, ``n`` the unit gradient; a gap of at least 1e-6 mm keeps the
    direction when ``v`` is ~0); no pair (and ``inf``) where the gradient vanishes."""
    length = np.sqrt(_dist_sq(p0, p1))
    n = max(int(np.ceil(2.0 * length / g.h)), 1)
    p, grad = np.empty(3), np.empty(3)
    best = np.inf
    for i in range(n + 1):
        _lerp(p0, p1, i / n, p)
        v = grid_sd(m, g, p, grad)
        norm = np.sqrt(_dot(grad, grad))
        if v < best and norm > 1e-9:
            best = v
            gap = v if abs(v) > 1e-6 else (1e-6 if v >= 0.0 else -1e-6)
            for a in range(3):
                pair[0, a] = p[a]
                pair[1, a] = p[a] - gap * grad[a] / norm
    return best


# -- the friendly wrapper ---------------------------------------------------------------
class MeshDistance:
    """Distances to one closed, outward-oriented triangle mesh (see the module docstring).

    Args:
        vertices: (V, 3) [mm].
        faces: (F, 3) vertex indices, counter-clockwise seen from outside.
    """

    def __init__(self, vertices, faces):
        self.arrays = build_mesh_arrays(vertices, faces)

    def __getstate__(self):
        return {"arrays": tuple(self.arrays)}

    def __setstate__(self, state):
        self.arrays = MeshArrays(*state["arrays"])

    def sd_grid(self) -> SdGrid:
        """This mesh's lazily filled :class:`SdGrid` (made on first use, kept with the mesh,
        never pickled: each process fills its own)."""
        grid = self.__dict__.get("_sd_grid")
        if grid is None:
            grid = self._sd_grid = new_sd_grid(self.arrays)
        return grid

    @property
    def face_normals(self) -> np.ndarray:
        """(F, 3) unit outward normals in the original face order."""
        out = np.empty_like(self.arrays.face_normal)
        out[self.arrays.face_id] = self.arrays.face_normal
        return out

    def signed_distance(self, points, *, closest: bool = False):
        """``points (N, 3) -> (N,)`` [mm], negative inside; with ``closest=True`` also the
        closest surface points (N, 3)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        q = np.empty_like(p)
        d = aot(signed_distances)(self.arrays, p, q)
        return (d, q) if closest else d

    def segment_distance(self, starts, ends) -> np.ndarray:
        """Unsigned distance of segments ``starts (N, 3)``-``ends (N, 3)`` to the surface (N,) [mm]."""
        a = np.ascontiguousarray(np.asarray(starts, dtype=float).reshape(-1, 3))
        b = np.ascontiguousarray(np.asarray(ends, dtype=float).reshape(-1, 3))
        return segment_distances(self.arrays, a, b)

    def closest_pair(self, start, end):
        """``(distance [mm], point on the segment (3,), point on the surface (3,))`` of one
        segment ``start (3,)``-``end (3,)``; the points are ``None`` when the segment meets
        the surface (distance 0)."""
        a = np.ascontiguousarray(np.asarray(start, dtype=float).reshape(3))
        b = np.ascontiguousarray(np.asarray(end, dtype=float).reshape(3))
        ps, pm = np.empty(3), np.empty(3)
        d = float(segment_closest(self.arrays, a, b, ps, pm))
        return (d, ps, pm) if d > 0.0 else (0.0, None, None)

    def capsule_depth(self, starts, ends, radius, step: float = 0.25, cap: float = np.inf) -> np.ndarray:
        """Penetration depth of capsules ``starts (N, 3)``-``ends (N, 3)``, ``radius (N,)`` [mm], (N,) [mm];
        with ``cap`` [mm], depths above it may be returned as any value above it (see
        :func:`capsule_depths`: much cheaper for a yes/no test)."""
        a = np.ascontiguousarray(np.asarray(starts, dtype=float).reshape(-1, 3))
        b = np.ascontiguousarray(np.asarray(ends, dtype=float).reshape(-1, 3))
        r = np.array(radius, dtype=float).reshape(-1)  # a writable copy: one compiled signature for every caller
        return aot(capsule_depths)(self.arrays, a, b, r, float(step), float(cap))

    def closest_faces(self, points) -> np.ndarray:
        """Index (in the original mesh) of the face closest to each point, (N,)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        return self.arrays.face_id[_closest_face_ids(self.arrays, p)]


@njit(cache=True)
def _closest_face_ids(m, points):
    out = np.empty(points.shape[0], np.int64)
    q = np.empty(3)
    for i in range(points.shape[0]):
        out[i] = _point_query(m, points[i], q)[1]
    return out
