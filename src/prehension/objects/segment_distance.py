"""Compiled segment queries of a closed triangle mesh (:class:`~.mesh_arrays.MeshArrays`):
distance, closest pair, smallest signed distance along a segment, and capsule depths.

The distance of a segment to the surface (0 when it crosses it) is the minimum over
triangles of the closed-form segment-triangle distance (Ericson, *Real-Time Collision
Detection*, 5.1.5 and 5.1.9: the segment's ends against the triangle, the segment against
its edges, :func:`prehension.kernels.segments.segment_params` with
:data:`~prehension.kernels.segments.MESH_EPS`); the tree is searched with a lower bound per
box.  :func:`segment_closest` also returns the closest pair (a point of the segment, a
point of the surface), for the local solver's penetration rows; :func:`segment_min_sd` and
:func:`capsule_depths` measure how deep a segment (a capsule) reaches into the solid, as
the one residual function and the local solver's rows read it.  mm.
"""

from __future__ import annotations

import numpy as np

from ..kernels.jit import njit
from ..kernels.segments import MESH_EPS, segment_distance_sq, segment_params
from .mesh_arrays import STACK_DEPTH
from .point_distance import box_box_sq, closest_on_triangle, dist_sq, signed_distance_at

__all__ = [
    "segment_closest", "segment_closest_within", "segment_query_within", "segment_distances", "segment_min_sd",
    "capsule_depths", "lerp", "REL_TOL",
]  # fmt: skip

@njit(cache=True)
def _box_segment_sq(lo, hi, p0, p1, seg_lo, seg_hi):
    """A lower bound of the squared distance from box ``lo``-``hi`` to segment ``p0``-``p1``
    (whose own box is ``seg_lo``-``seg_hi``): the larger of the two boxes' distance and the
    distance from the box's centre to the segment less the box's half diagonal (its
    bounding sphere), made smaller by 1e-9 mm so that rounding never makes it exceed the
    true distance.  The sphere's bound is the tight one for a long segment across the
    mesh, whose own box holds many boxes that the segment passes far from."""
    d_box = box_box_sq(lo, hi, seg_lo, seg_hi)
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
    closest_on_triangle(p0, a, b, c, q)
    best = dist_sq(p0, q)
    closest_on_triangle(p1, a, b, c, q)
    best = min(best, dist_sq(p1, q))
    best = min(best, segment_distance_sq(p0, p1, a, b, MESH_EPS))
    best = min(best, segment_distance_sq(p0, p1, b, c, MESH_EPS))
    return min(best, segment_distance_sq(p0, p1, c, a, MESH_EPS))


@njit(cache=True)
def _segment_query(m, p0, p1):
    """Squared distance from segment ``p0``-``p1`` to the surface (0 when it crosses it)."""
    return segment_query_within(m, p0, p1, np.inf)


@njit(cache=True)
def segment_query_within(m, p0, p1, bound):
    """As :func:`_segment_query`, pruning from the start every box farther than ``bound``
    (squared): the squared distance when it is below ``bound``, else ``bound``.  Below the
    bound, the same value as the unbounded search (the same triangles' minimum)."""
    lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
    best = bound
    q = np.empty(3)
    stack = np.empty(STACK_DEPTH, np.int64)
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
        if box_box_sq(m.node_lo[l], m.node_hi[l], lo, hi) < box_box_sq(m.node_lo[r], m.node_hi[r], lo, hi):
            stack[top], stack[top + 1] = r, l  # the nearer child is visited first
        else:
            stack[top], stack[top + 1] = l, r
        top += 2
    return best


@njit(cache=True)
def lerp(p0, p1, s, out):
    for i in range(3):
        out[i] = p0[i] + s * (p1[i] - p0[i])


@njit(cache=True)
def _segment_triangle_pair(p0, p1, a, b, c, q, ps, pm):
    """Squared distance of segment p0p1 to triangle abc, 0 when they meet; otherwise a
    closest pair, ``ps`` on the segment and ``pm`` on the triangle (left as they are when 0)."""
    if _segment_crosses(p0, p1, a, b, c):
        return 0.0
    closest_on_triangle(p0, a, b, c, pm)
    best = dist_sq(p0, pm)
    ps[0], ps[1], ps[2] = p0[0], p0[1], p0[2]
    closest_on_triangle(p1, a, b, c, q)
    d = dist_sq(p1, q)
    if d < best:
        best = d
        ps[0], ps[1], ps[2] = p1[0], p1[1], p1[2]
        pm[0], pm[1], pm[2] = q[0], q[1], q[2]
    for i in range(3):
        A = a if i == 0 else (b if i == 1 else c)
        B = b if i == 0 else (c if i == 1 else a)
        d, s, t = segment_params(p0, p1, A, B, MESH_EPS)
        if d < best:
            best = d
            lerp(p0, p1, s, ps)
            lerp(A, B, t, pm)
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
    stack = np.empty(STACK_DEPTH, np.int64)
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
        if box_box_sq(m.node_lo[l], m.node_hi[l], lo, hi) < box_box_sq(m.node_lo[r], m.node_hi[r], lo, hi):
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
        lerp(p0, p1, t, p)
        v = signed_distance_at(m, p, q, abs(v_prev) + length / n if i > 0 else np.inf)
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
        lerp(p0, p1, tm, p)
        vm = signed_distance_at(m, p, q, min(abs(va), abs(vb)) + 0.5 * span)
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
    near = d + np.sqrt(dist_sq(p0, pair[0])) if d < bound else np.inf  # p0 is no farther
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
    return signed_distance_at(m, p0, q, near) > 0.0


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
        d = np.sqrt(segment_query_within(m, starts[i], ends[i], reach * reach))
        near = d + np.sqrt(dist_sq(starts[i], ends[i])) if d < reach else np.inf  # starts[i] no farther
        if _wholly_outside(m, starts[i], d, near):  # exact (0 beyond the reach)
            out[i] = max(0.0, radius[i] - d) if d < reach else 0.0
        elif radius[i] + d > cap:  # touching or inside: at least r (+ d when wholly inside)
            out[i] = radius[i] + d
        else:  # as segment_min_sd, without its closest pair
            out[i] = radius[i] - min(_sampled_min_sd(m, starts[i], ends[i], step, pair, 0.0), 0.0)
    return out
