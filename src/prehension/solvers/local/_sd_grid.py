"""A lazily filled grid of a mesh's signed distance: what the kernel's *seeing* rows read.

The local solver's seeing iterations (:func:`._kernel.iterate` with ``seeing``) stack a
row per capsule near the object; measuring each exactly (:mod:`prehension.objects.segment_distance`)
at every step costs more than the rows are worth, as they only steer the iterations.
They read the trilinear interpolation of the signed distance at the nodes of a regular
grid instead (:func:`grid_segment_min_sd`), each node computed exactly the first time it
is read; every verdict still comes from the exact queries.
"""

from __future__ import annotations

import numpy as np

from ...frozen import cached_per_value
from ...kernels.jit import njit
from ...objects.distance import MeshDistance
from ...objects.mesh_arrays import MeshArrays, SdGrid
from ...objects.point_distance import dot3, dist_sq, signed_distance_at
from ...objects.segment_distance import lerp

__all__ = ["SdGrid", "sd_grid_of", "new_sd_grid", "empty_sd_grid", "in_grid", "grid_span", "grid_sd", "grid_segment_min_sd",
           "GRID_PAD_MM"]

GRID_PAD_MM = 20.0  # the grid covers the mesh's box grown by this much on every side
# Finest spacing.  Measured (2026-11-23, builtin tasks x8 in one batch, and the 39 tasks of
# benchmarks/objects.py): 4-6 mm steer the seeing runs as well as 2 mm (same statuses on all
# 39 tasks) at a third of the node fills; mean solve 5.7 ms at 2, 7.1 at 3 (one task's
# seeing runs went astray), 4.0 at 4, 3.8 at 5, 4.5 at 6, 11.7 at 8 mm: 5 mm, in the middle
# of the good range.
GRID_MIN_H_MM = 5.0
GRID_MAX_NODES = 2_000_000  # coarser than GRID_MIN_H_MM when the box would need more (8 MB of float32)


@cached_per_value
def sd_grid_of(distance: MeshDistance) -> SdGrid:
    """The lazily filled :class:`SdGrid` of a mesh (made on first use, kept beside the
    :class:`~prehension.objects.distance.MeshDistance` in a weak cache, never pickled with
    it: each process fills its own)."""
    return new_sd_grid(distance.arrays)


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
    g.val[i, j, k] = signed_distance_at(m, p, q, np.inf)


@njit(cache=True)
def in_grid(g, p):
    """Whether ``p`` (3,) lies in the grid's box (a cell of it holds it)."""
    for a in range(3):
        u = (p[a] - g.lo[a]) / g.h
        if not (0.0 <= u <= g.val.shape[a] - 1):
            return False
    return True


@njit(cache=True)
def grid_span(g, p0, p1):
    """The part of segment ``p0``-``p1`` inside the grid's box, as the interval ``(u0, u1)``
    of its parameter in [0, 1] (``u0 > u1``: none of it).  The rest lies at least
    :data:`GRID_PAD_MM` from the mesh's box, so at least that far from the surface, outside."""
    u0, u1 = 0.0, 1.0
    for a in range(3):
        lo, hi = g.lo[a], g.lo[a] + (g.val.shape[a] - 1) * g.h
        d = p1[a] - p0[a]
        if abs(d) < 1e-12:
            if p0[a] < lo or p0[a] > hi:
                return 1.0, 0.0
            continue
        s, e = (lo - p0[a]) / d, (hi - p0[a]) / d
        u0, u1 = max(u0, min(s, e)), min(u1, max(s, e))
    return u0, u1


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
def _trilinear(g, x, y, z):
    """The trilinear value of the grid at ``(x, y, z)``: NaN where a node of its cell is not
    computed yet.  Calls nothing: a loop of these stays free of the reference counting a call
    with the grid's arrays costs (measured: 15x the reads)."""
    val, h, lo = g.val, g.h, g.lo
    u, v, w = (x - lo[0]) / h, (y - lo[1]) / h, (z - lo[2]) / h
    i = min(max(int(np.floor(u)), 0), val.shape[0] - 2)
    j = min(max(int(np.floor(v)), 0), val.shape[1] - 2)
    k = min(max(int(np.floor(w)), 0), val.shape[2] - 2)
    a, b, c = u - i, v - j, w - k
    c00 = val[i, j, k] * (1 - a) + val[i + 1, j, k] * a
    c10 = val[i, j + 1, k] * (1 - a) + val[i + 1, j + 1, k] * a
    c01 = val[i, j, k + 1] * (1 - a) + val[i + 1, j, k + 1] * a
    c11 = val[i, j + 1, k + 1] * (1 - a) + val[i + 1, j + 1, k + 1] * a
    return (c00 * (1 - b) + c10 * b) * (1 - c) + (c01 * (1 - b) + c11 * b) * c


@njit(cache=True)
def _samples_min(g, p0, p1, n):
    """The smallest :func:`_trilinear` value over samples ``i / n`` of segment ``p0``-``p1``
    and its parameter; NaN first where a sample's cell is not computed yet."""
    best, at = np.inf, 0.0
    for i in range(n + 1):
        t = i / n
        v = _trilinear(g, p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1]), p0[2] + t * (p1[2] - p0[2]))
        if v != v:
            return v, t
        if v < best:
            best, at = v, t
    return best, at


@njit(cache=True)
def grid_segment_min_sd(m, g, p0, p1, pair):
    """The smallest trilinear signed distance (:func:`grid_sd`) over samples at most half
    a spacing apart along segment ``p0``-``p1`` (both in the grid) [mm], and where:
    ``pair[0]`` the sample, ``pair[1]`` the surface point its value and gradient point at
    (``pair[0] - v n``, ``n`` the unit gradient; a gap of at least 1e-6 mm keeps the
    direction when ``v`` is ~0); no pair (and ``inf``) where that gradient vanishes.  The
    samples are read without their gradients, which only the smallest one's pair needs,
    and without a call (:func:`_trilinear`); a cell not computed yet is filled and the
    samples read again."""
    length = np.sqrt(dist_sq(p0, p1))
    n = max(int(np.ceil(2.0 * length / g.h)), 1)
    p, grad = pair[0], pair[1]
    best, at = _samples_min(g, p0, p1, n)
    while best != best:  # fill the first cell not computed yet, read again
        lerp(p0, p1, at, p)
        grid_sd(m, g, p, grad)
        best, at = _samples_min(g, p0, p1, n)
    lerp(p0, p1, at, p)
    best = grid_sd(m, g, p, grad)
    norm = np.sqrt(dot3(grad, grad))
    if norm <= 1e-9:
        return np.inf
    gap = best if abs(best) > 1e-6 else (1e-6 if best >= 0.0 else -1e-6)
    for a in range(3):
        grad[a] = p[a] - gap * grad[a] / norm
    return best
