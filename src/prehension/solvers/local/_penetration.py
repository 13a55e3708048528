"""Hand-object penetration rows of the kernel: each checked capsule against the object's solid.

The kernel's second kind of inequality row (the first is self-collision, in
:mod:`._model`).  For each capsule (segment ``a``-``b``, radius ``r``) of the links that
move with the task (the palm and the fingers taking part; idle fingers are cleared
afterwards by :func:`~prehension.tasks.idle.settle_idle_fingers`), its **value** is

    ``min over the kept pieces of the segment of (sd - r)``  [mm], wanted ``>= 0``,

where ``sd`` is the signed distance to the surface (negative inside), and the kept pieces
are those of :func:`prehension.tasks.object_collision._kept_pieces`: the parts of the
segment whose capsule balls do not lie inside a pad of the capsule's link, i.e. the
segment less ``|p - c| <= rho - r`` for each contact on that link (``c`` the pad's centre
``ph - rho nh``: a fingertip cap's centre, fixed on the link; ``rho`` its radius, 0 for a
point or patch hand region, which excuses nothing).  So ``max(0, -value)`` is exactly the depth the
one residual function reports for that capsule (:func:`~prehension.objects.distance.capsule_depths`:
the exact segment distance when the piece is outside the solid, else the sampled minimum:
within ``step / 2`` there, within ``max(step / 2, depth / 8)`` here
(:data:`~prehension.objects.distance.REL_TOL`: the rows need no more), and the kernel and
the residual function agree on what counts (a piece reaching in is deeper than its
radius for both).

**The pads' rows** (:func:`pad_rows`).  Each contact's pad is itself checked, as the
residual function does: its value is ``sd(c) - rho`` (``max(0, -value)`` the pad depth
the residual function reports, exact).  A pad touches the object at its contact, so it
is held to a depth, not to a clearance: it counts as clear down to
:data:`PAD_CLEAR_MM` deep (the residual function allows 0.5 mm), and a pad deeper than
:data:`PAD_ROW_MM` gets a row that pushes it back to that depth (a pad touching a
surface that agrees with its region has no row: the row never fights the contact).

**Its gradient.**  With the closest pair ``(p, s)`` -- ``p`` on the segment (fixed on the
link), ``s`` on the surface (fixed on the object) -- and ``n`` the outward unit normal
``(p - s) / sd``, a motion changes the value by ``n . (dp - ds)``: joint columns
``n . (w_d x (p - o_d))`` for the angles that move the link, twist columns ``-(s - c) x n``
(rotation about the pivot ``c``) and ``-n`` (translation).  The pad cut's ends are held
fixed on the link (their sliding along the segment as the contact point moves is
neglected, a second-order effect near a contact).  ``tests/test_object_kernel.py`` checks
the rows against finite differences.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...kernels.jit import njit
from ...objects.mesh_arrays import MeshArrays, empty_mesh_arrays
from ...objects.point_distance import signed_distance_at
from ...objects.segment_distance import REL_TOL, segment_min_sd
from ._linalg import cross, mat_vec
from ._sd_grid import GRID_PAD_MM, SdGrid, empty_sd_grid, grid_segment_min_sd, grid_span, in_grid

__all__ = ["ObjectArrays", "NO_OBJECT", "object_rows", "capsule_rows", "pad_rows", "surely_in_object", "PAD_ROW_MM", "PAD_CLEAR_MM"]

PAD_ROW_MM = 0.2  # a pad deeper than this into the object gets a row, which pushes it back to this depth [mm]
PAD_CLEAR_MM = 0.35  # a pad this deep or less is clear (the residual function allows 0.5 mm) [mm]


class ObjectArrays(NamedTuple):
    """The object's solid as the kernel reads it (one per group).

    ``mesh`` (:class:`~prehension.objects.distance.MeshArrays`, object frame, mm);
    ``active``: whether rows are made (a task whose object collides); ``checked``
    (n_caps,) bool: the capsules checked (links that move with the task); ``pad`` (C,)
    each contact's pad radius [mm] (0 for a point or patch hand region); ``step``: spacing of the depth samples of a piece
    that reaches inside [mm] (the residual function's
    :data:`~prehension.tasks.object_collision.SAMPLE_MM`); ``grid``: the mesh's lazily
    filled signed-distance grid (:class:`._sd_grid.SdGrid`), which the
    seeing iterations' rows read instead of the exact queries.
    """

    mesh: MeshArrays
    active: bool
    checked: np.ndarray
    pad: np.ndarray
    step: float
    grid: SdGrid


def no_object(n_contacts: int = 0) -> ObjectArrays:
    """An inactive :class:`ObjectArrays` (same numba type): no rows are made."""
    return ObjectArrays(empty_mesh_arrays(), False, np.zeros(0, dtype=np.bool_), np.zeros(n_contacts), 0.25, empty_sd_grid())


NO_OBJECT = no_object()


# -- one capsule -----------------------------------------------------------------------------
@njit(cache=True)
def _cut(ws, s, cut):
    """The pieces of capsule ``s``'s segment whose balls do not lie inside a pad of its
    link, as parameter intervals ``cut[0, :n]`` of ``[0, 1]`` (``_kept_pieces``: the
    segment less ``|p - c| <= rho - r``, ``c`` the pad's centre ``ph - rho nh``); returns ``n``."""
    lay, obj = ws.lay, ws.obj
    a, b = ws.ends[s, 0], ws.ends[s, 1]
    dd = (b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2
    cut[0, 0, 0], cut[0, 0, 1] = 0.0, 1.0
    n = 1
    for c in range(lay.link.shape[0]):
        R = obj.pad[c] - ws.hand.cap_radius[s]
        if lay.link[c] != ws.hand.cap_link[s] or R <= 0.0:
            continue  # another link's pad, or one no thicker than the capsule: nothing inside it
        ff = fd = 0.0
        for i in range(3):
            f = a[i] - (ws.ph[c, i] - obj.pad[c] * ws.nh[c, i])
            ff += f * f
            fd += f * (b[i] - a[i])
        if dd <= 1e-18:
            lo, hi = (0.0, 1.0) if ff <= R * R else (1.0, 0.0)
        else:
            bq, cq = fd / dd, (ff - R * R) / dd
            disc = bq * bq - cq
            if disc <= 0.0:
                continue
            lo, hi = -bq - math.sqrt(disc), -bq + math.sqrt(disc)
        m = 0
        for k in range(n):
            s0, e0 = cut[0, k, 0], cut[0, k, 1]
            if min(e0, lo) > s0:
                cut[1, m, 0], cut[1, m, 1], m = s0, min(e0, lo), m + 1
            if e0 > max(s0, hi):
                cut[1, m, 0], cut[1, m, 1], m = max(s0, hi), e0, m + 1
        for k in range(m):
            cut[0, k, 0], cut[0, k, 1] = cut[1, k, 0], cut[1, k, 1]
        n = m
    return n


@njit(cache=True)
def _piece_end(ws, s, u, out):
    """Point ``u`` in [0, 1] of capsule ``s``'s segment, in the object frame: ``R^T (p - t)``."""
    for i in range(3):
        ws.vec[i] = ws.ends[s, 0, i] + u * (ws.ends[s, 1, i] - ws.ends[s, 0, i]) - ws.t[i]
    for i in range(3):
        out[i] = ws.R[0, i] * ws.vec[0] + ws.R[1, i] * ws.vec[1] + ws.R[2, i] * ws.vec[2]


@njit(cache=True)
def _capsule_value(ws, s, best, reach, coarse):
    """Capsule ``s``'s value ``min (sd - r)`` over its kept pieces [mm] (``1e300`` when
    the pads cover it; at least ``reach`` is all that is known of a capsule whose value is
    at least ``reach``), with the worst piece's pair (object frame) in ``best (2, 3)`` and
    that pair's distance [mm] (0: no direction) second.  ``coarse``: a piece inside the
    grid's box is measured on the grid (:func:`._sd_grid.grid_segment_min_sd`): its part
    inside the box, when the rest, at least :data:`~._sd_grid.GRID_PAD_MM` from the
    surface, is clear of the object (a capsule of radius ``r <= GRID_PAD_MM``: every capsule
    of the hands shipped), and a piece wholly outside the box counts as farther than the
    reach.  These rows only steer (a capsule just within the reach outside the box gets
    none); an exact query costs tens of microseconds, a grid read well under one."""
    obj, oseg = ws.obj, ws.oseg
    value = 1e300
    coarse = coarse and obj.grid.val.shape[0] > 1 and ws.hand.cap_radius[s] <= GRID_PAD_MM
    for k in range(_cut(ws, s, ws.cut)):
        u0, u1 = ws.cut[0, k, 0], ws.cut[0, k, 1]
        if coarse:  # on the grid, the piece's part inside the grid's box (the rest is clear of the object)
            _piece_end(ws, s, u0, oseg[0])
            _piece_end(ws, s, u1, oseg[1])
            g0, g1 = grid_span(obj.grid, oseg[0], oseg[1])
            if g0 > g1:
                value = min(value, reach)
                continue
            u0, u1 = u0 + g0 * (u1 - u0), u0 + g1 * (u1 - u0)
        _piece_end(ws, s, u0, oseg[0])
        _piece_end(ws, s, u1, oseg[1])
        if coarse:
            sd = grid_segment_min_sd(obj.mesh, obj.grid, oseg[0], oseg[1], oseg[2:4])
        else:
            sd = segment_min_sd(obj.mesh, oseg[0], oseg[1], obj.step, oseg[2:4], ws.hand.cap_radius[s] + reach, REL_TOL)
        if sd - ws.hand.cap_radius[s] >= reach:
            value = min(value, reach)  # no row: farther than the reach
            continue
        if sd - ws.hand.cap_radius[s] < value:
            value = sd - ws.hand.cap_radius[s]
            best[0] = oseg[2]
            best[1] = oseg[3]
    gap = 0.0
    if value < 1e299:
        gap = math.sqrt((best[0, 0] - best[1, 0]) ** 2 + (best[0, 1] - best[1, 1]) ** 2 + (best[0, 2] - best[1, 2]) ** 2)
    return value, gap


@njit(cache=True)
def _far_from_object(ws, s, margin):
    """Broad phase: capsule ``s``'s bounding sphere is farther than ``margin`` from the
    mesh's bounding box."""
    m = ws.obj.mesh
    _piece_end(ws, s, 0.5, ws.oseg[4])
    d2 = 0.0
    for i in range(3):
        p = ws.oseg[4, i]
        d2 += max(m.node_lo[0, i] - p, 0.0, p - m.node_hi[0, i]) ** 2
    return math.sqrt(d2) >= ws.half[s] + margin


# -- the row ---------------------------------------------------------------------------------
@njit(cache=True)
def _penetration_row(ws, data, li, outward, row):
    """Row ``row`` of ``ws.M``: the gradient of a value of link ``li`` (a capsule's or a
    pad's) in ``x`` at the pair ``ws.oseg[5:7]`` (object frame): ``outward`` is +1 when the
    link's point is outside (the outward normal points from the surface point to it), -1 inside."""
    hand, lay, M, nf = ws.hand, ws.lay, ws.M, ws.lay.nf
    n, p, q, cp = ws.pa, ws.pb, ws.tmp[0, 0], ws.tmp[0, 1]
    gap = math.sqrt((ws.oseg[5, 0] - ws.oseg[6, 0]) ** 2 + (ws.oseg[5, 1] - ws.oseg[6, 1]) ** 2 + (ws.oseg[5, 2] - ws.oseg[6, 2]) ** 2)
    for i in range(3):
        ws.vec[i] = outward * (ws.oseg[5, i] - ws.oseg[6, i]) / gap  # outward normal, object frame
    mat_vec(ws.R, ws.vec, n)
    mat_vec(ws.R, ws.oseg[5], p)
    mat_vec(ws.R, ws.oseg[6], q)
    mat_vec(ws.R, data[lay.pivot_offset : lay.pivot_offset + 3], cp)
    for i in range(3):
        p[i] += ws.t[i]
        q[i] += ws.t[i]
        cp[i] += ws.t[i]
    for j in range(M.shape[1]):
        M[row, j] = 0.0
    for d in range(lay.dof_free.shape[0]):
        col = lay.dof_free[d]
        if col < 0 or not hand.moves[li, d]:
            continue
        for i in range(3):
            ws.vec[i] = p[i] - ws.org[d, i]
        cross(ws.ax[d], ws.vec, ws.tmp[0, 2])
        M[row, col] += lay.dof_ratio[d] * (n[0] * ws.tmp[0, 2, 0] + n[1] * ws.tmp[0, 2, 1] + n[2] * ws.tmp[0, 2, 2])
    for i in range(3):
        ws.vec[i] = q[i] - cp[i]
    cross(ws.vec, n, ws.tmp[0, 2])
    for i in range(3):
        M[row, nf + i] = -ws.tmp[0, 2, i]
        M[row, nf + 3 + i] = -n[i]


@njit(cache=True)
def capsule_rows(ws, data, margin, row0, max_rows, every):
    """The capsules' part of :func:`object_rows` (without the pads' rows).

    Rows ``value - margin`` of the checked capsules whose value (see the module
    docstring) is below ``margin`` [mm], into ``ws.M``, ``ws.g`` from ``row0``, at most
    ``max_rows``; ``(rows written, smallest value seen)``, a capsule farther than the margin
    counted as ``margin`` (its distance is searched only up to there).  The capsules must be placed
    (:func:`._model.place_capsules`) and the contact points ``ws.ph`` current.  ``row0`` and
    ``max_rows`` are int64: callers pass ``np.int64(0)``, never a literal ``0``, so that the
    function compiles once (see :mod:`prehension.kernels.jit`).  ``every`` (``np.bool_``): the rows of
    :func:`._kernel.iterate`'s seeing steps: the idle fingers' capsules too, at their idle
    angles (rows in the object pose's columns only), so that the idle fingers need no
    settling out of a palm that approached the object; and values read on the mesh's
    signed-distance grid (``obj.grid``: cheap, approximate -- these rows only steer the
    iterations; the seeing answer's clearance is then measured exactly)."""
    obj = ws.obj
    nrows, vmin = 0, 1e300
    if not obj.active:
        return 0, vmin
    for s in range(ws.hand.cap_link.shape[0]):
        if not (obj.checked[s] or every) or _far_from_object(ws, s, margin):
            continue
        value, gap = _capsule_value(ws, s, ws.oseg[5:7], margin, every)
        vmin = min(vmin, value)
        if value < margin and nrows < max_rows and gap > 1e-9:
            _penetration_row(ws, data, ws.hand.cap_link[s], 1.0 if value + ws.hand.cap_radius[s] >= 0.0 else -1.0, row0 + nrows)
            ws.g[row0 + nrows] = value - margin
            nrows += 1
    return nrows, vmin


@njit(cache=True)
def object_rows(ws, data, margin, row0, max_rows, every):
    """The object's rows: the capsules' (:func:`capsule_rows`), then the pads'
    (:func:`pad_rows`); ``(rows written, smallest value seen)``; none without an object."""
    if not ws.obj.active:
        return 0, 1e300
    nrows, vmin = capsule_rows(ws, data, margin, row0, max_rows, every)
    n_pads, vpad = pad_rows(ws, data, row0 + nrows, max_rows - nrows, every)
    return nrows + n_pads, min(vmin, vpad)


@njit(cache=True)
def _point_sd(m, p, pair, bound):
    """:func:`~prehension.objects.segment_distance.segment_min_sd` of the point ``p`` (3,),
    in one query: its signed distance, ``bound`` when it lies outside and farther (then no
    pair); ``pair[0]`` the point, ``pair[1]`` its closest surface point.  The same value:
    for a point, the segment's sampled minimum inside is the point's own (measured: a third
    of the time)."""
    sd = signed_distance_at(m, p, pair[1], bound)
    if sd >= bound:
        return bound
    for i in range(3):
        pair[0, i] = p[i]
    return sd


@njit(cache=True)
def surely_in_object(ws):
    """Whether the grid proves that a checked capsule reaches into the object, so that the
    exact clearance (:func:`object_rows`) is negative without being measured.

    The trilinear reading ``I(p)`` is within ``h sqrt(3)`` of the signed distance (a convex
    combination of the cell's corner values, each exact and within its distance from ``p``:
    sd is 1-Lipschitz; ``tests/test_mesh_distance.py``), so ``I(p) + h sqrt(3) < r`` at a
    sample ``p`` of a kept piece (:func:`_cut`: outside the pads) gives ``sd(p) - r < 0``:
    the exact value of that capsule is negative (the exact distance of a piece wholly
    outside is at most ``sd(p)``; a piece meeting the surface counts at most ``-r``).  False
    says nothing: the exact query decides.  The capsules must be placed
    (:func:`._model.place_capsules`) and the contact points ``ws.ph`` current."""
    obj, oseg = ws.obj, ws.oseg
    g = obj.grid
    if not obj.active or g.val.shape[0] <= 1:
        return False
    err = g.h * math.sqrt(3.0) + 1e-3  # and the float32 storage's rounding
    for s in range(ws.hand.cap_link.shape[0]):
        if not obj.checked[s] or _far_from_object(ws, s, 0.0):
            continue
        for k in range(_cut(ws, s, ws.cut)):
            u0, u1 = ws.cut[0, k, 0], ws.cut[0, k, 1]
            _piece_end(ws, s, u0, oseg[0])
            _piece_end(ws, s, u1, oseg[1])
            g0, g1 = grid_span(g, oseg[0], oseg[1])
            if g0 > g1:
                continue
            _piece_end(ws, s, u0 + g0 * (u1 - u0), oseg[0])
            _piece_end(ws, s, u0 + g1 * (u1 - u0), oseg[1])
            if grid_segment_min_sd(obj.mesh, g, oseg[0], oseg[1], oseg[2:4]) + err < ws.hand.cap_radius[s]:
                return True
    return False


@njit(cache=True)
def pad_rows(ws, data, row0, max_rows, coarse):
    """Each contact's pad against the object (see the module docstring): rows
    ``sd(c) - rho + PAD_ROW_MM`` of the pads deeper than :data:`PAD_ROW_MM`, from ``row0``,
    at most ``max_rows``; ``(rows written, smallest value sd(c) - rho + PAD_CLEAR_MM)``.
    ``coarse`` (``np.bool_``; the seeing steps): a pad centre in the grid's box whose grid value
    is more than a grid spacing from the row's depth is read on the grid (no exact query:
    these rows only steer), the others exactly."""
    obj, lay, oseg = ws.obj, ws.lay, ws.oseg
    nrows, vmin = 0, 1e300
    for c in range(lay.link.shape[0]):
        for i in range(3):
            ws.vec[i] = ws.ph[c, i] - obj.pad[c] * ws.nh[c, i] - ws.t[i]  # the pad's centre, palm frame less t
        for i in range(3):
            oseg[0, i] = ws.R[0, i] * ws.vec[0] + ws.R[1, i] * ws.vec[1] + ws.R[2, i] * ws.vec[2]
        sd = np.inf
        if coarse and obj.grid.val.shape[0] > 1 and in_grid(obj.grid, oseg[0]):
            sd = grid_segment_min_sd(obj.mesh, obj.grid, oseg[0], oseg[0], oseg[5:7])
            if abs(sd - obj.pad[c] + PAD_ROW_MM) < obj.grid.h:  # near the row's depth: measured exactly
                sd = np.inf
        if sd == np.inf:
            sd = _point_sd(obj.mesh, oseg[0], oseg[5:7], obj.pad[c] + PAD_CLEAR_MM)
        value = sd - obj.pad[c]
        vmin = min(vmin, value + PAD_CLEAR_MM)
        gap = math.sqrt((oseg[5, 0] - oseg[6, 0]) ** 2 + (oseg[5, 1] - oseg[6, 1]) ** 2 + (oseg[5, 2] - oseg[6, 2]) ** 2)
        if value < -PAD_ROW_MM and nrows < max_rows and gap > 1e-9:
            _penetration_row(ws, data, lay.link[c], 1.0 if sd >= 0.0 else -1.0, row0 + nrows)
            ws.g[row0 + nrows] = value + PAD_ROW_MM
            nrows += 1
    return nrows, vmin
