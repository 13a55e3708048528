r"""Linear relaxations of the Psi equations on a box (Rosales et al. 2011, sec. 4.3, Fig. 5).

Every function here returns linear inequalities ``a . x <= d`` that hold for **every
real solution** of the relaxed equation inside the box ``[l, u]``, rounding included:
the coefficients ``a`` are whatever floats we choose, and each offset ``d`` is rounded
(or padded) outwards so that the inequality is valid for the exact real solutions.

Squares, ``x_k = x_i^2`` on ``[l, u] = [l_i, u_i]`` (triangle ``A1 A2 A3`` of Fig. 5a)
--------------------------------------------------------------------------------------
* secant (chord through ``A1, A2``): ``x_k - s x_i <= d`` with ``s = fl(l + u)``.  The
  exact chord is ``x^2 <= (l + u) x - l u`` because ``(x - l)(x - u) <= 0``.  With the
  rounded slope ``s`` we use ``d = max_{e in {l, u}} (e^2 - s e)`` rounded up: ``x^2 - s x``
  is convex, so its maximum over ``[l, u]`` is at an endpoint.
* tangents at ``t in {l, u}`` (edges ``A1 A3``, ``A2 A3``) and, by default, at the
  midpoint ``m = (l + u) / 2`` (cuts the apex ``A3`` off: the vertical gap of the
  relaxation drops from ``w^2 / 4`` to ``w^2 / 16``, ``w = u - l``):
  ``2 t x_i - x_k <= t^2`` because ``(x_i - t)^2 >= 0``.  This holds for *every* real
  ``x_i`` and every float ``t``; ``2 t`` is exact and ``t^2`` is rounded up.

Products, ``x_k = x_i x_j`` (tetrahedron ``B1..B4`` of Fig. 5b = McCormick envelope)
-------------------------------------------------------------------------------------
The four faces pass through three lifted corners of ``[l_i, u_i] x [l_j, u_j]``::

    l_j x_i + l_i x_j - x_k <=  l_i l_j     since (x_i - l_i)(x_j - l_j) >= 0
    u_j x_i + u_i x_j - x_k <=  u_i u_j     since (x_i - u_i)(x_j - u_j) >= 0
    x_k - l_j x_i - u_i x_j <= -u_i l_j     since (x_i - u_i)(x_j - l_j) <= 0
    x_k - u_j x_i - l_i x_j <= -l_i u_j     since (x_i - l_i)(x_j - u_j) <= 0

The coefficients are box bounds (exact floats); only the constant products are rounded
(outwards).

Bernstein equations, ``x_k = f(x_i, x_j)`` (convex hull of Fig. 5c, eq. 33)
--------------------------------------------------------------------------------
``f`` restricted to ``[l_i, u_i] x [l_j, u_j]`` has control points
``b' = S_u b S_v^T`` (:func:`~prehension.geometry.bezier.subdivision_matrix`).  With
``s, t in [0, 1]`` the surface point is exactly the convex combination, with weights
``B_p(s) B_q(t)``, of the points ``c_pq = (l_i + p/d_p (u_i - l_i), l_j + q/d_q (u_j - l_j),
b'_pq)`` (a direction of degree 0 is first elevated to degree 1 by repeating its
control points).  Hence for **any** direction ``a``::

    a . x <= max_pq a . c_pq          for every surface point x.

Qhull (:class:`scipy.spatial.ConvexHull`) is only used to *choose good directions* (the
facet normals of the hull of the ``c_pq``); the offsets are then recomputed as
``max_pq fl(a . c_pq)`` plus a rigorous bound of all rounding errors (on ``b'`` from
the subdivision, on the grid abscissae and on the dot products), rounded up.  So every
row is valid whatever Qhull returns, and degenerate point sets are easy:

* affine rank 3: the 3-D hull facets (coplanar triangles deduplicated);
* rank 2 (e.g. a zero-width interval, or a planar ``f``): the 2-D hull of the points in
  their plane, lifted to 3-D, plus the plane itself as two opposite rows;
* rank 1 (collinear): the line's direction and its two normals, both signs;
* rank 0 (a point): the six coordinate directions.

If Qhull still fails (nearly degenerate input), it is retried with ``"QJ"`` (joggled
input: a different but still useful set of directions, made valid by the recomputed
offsets), and as a last resort the lower-rank treatment is used.

Rounding bound for ``b'``: the arguments lie in ``[0, 1]`` (as the formulation
guarantees), so every entry of ``S_u, S_v`` is a sum of non-negative products and
``|fl(b') - b'| <= 8 (d_p + d_q + 4) eps (|S_u| |b| |S_v|^T)`` (about twice the
standard a-priori bound).

:func:`relaxation_rows` assembles all rows of a :class:`~prehension.system.System` on a box.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import ConvexHull, QhullError

from ...geometry.bezier import subdivision_matrix
from ...system.canonical import System
from .couplings import coupling_rows
from .rotation_cuts import RotationStructure, eigen_cuts, limit_cuts, limit_rows, rotation_rows

__all__ = [
    "down",
    "up",
    "square_relaxation",
    "product_relaxation",
    "bernstein_control_points",
    "bernstein_relaxation",
    "hull_directions",
    "relaxation_rows",
]

EPS = float(np.finfo(np.float64).eps)
TINY = float(np.finfo(np.float64).tiny)  # smallest normal: covers any underflow error
_RANK_TOL = 1e-9  # singular value (unit-extent coordinates) below which a direction is flat


def down(x):
    """Next float towards -inf: a lower bound of a once-rounded result (round-to-nearest)."""
    return np.nextafter(x, -np.inf)


def up(x):
    """Next float towards +inf: an upper bound of a once-rounded result."""
    return np.nextafter(x, np.inf)


# ----------------------------------------------------------------------------------
# Squares and products (vectorised)
# ----------------------------------------------------------------------------------
def square_relaxation(li, ui, midpoint: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Rows enclosing ``x_k = x_i^2`` for ``x_i in [li, ui]`` (batch).

    Args:
        li, ui: Interval bounds of ``x_i``, shape ``(B,)``, ``li <= ui``.
        midpoint: Add the tangent at the midpoint (4 rows instead of 3).

    Returns:
        ``coef (B, r, 2)`` over ``(x_i, x_k)`` and ``rhs (B, r)``: ``coef @ (x_i, x_k) <= rhs``.
    """
    li = np.asarray(li, dtype=float)
    ui = np.asarray(ui, dtype=float)
    s = li + ui
    with np.errstate(over="ignore", invalid="ignore"):
        d = np.maximum(up(up(li * li) - down(s * li)), up(up(ui * ui) - down(s * ui)))
    points = [li, ui] + ([0.5 * li + 0.5 * ui] if midpoint else [])
    coef = [np.stack([-s, np.ones_like(s)], axis=-1)]
    rhs = [d]
    for t in points:
        coef.append(np.stack([2.0 * t, -np.ones_like(t)], axis=-1))
        rhs.append(up(t * t))
    return np.stack(coef, axis=-2), np.stack(rhs, axis=-1)


def product_relaxation(li, ui, lj, uj) -> tuple[np.ndarray, np.ndarray]:
    """McCormick rows enclosing ``x_k = x_i x_j`` on ``[li, ui] x [lj, uj]`` (batch).

    Returns:
        ``coef (B, 4, 3)`` over ``(x_i, x_j, x_k)`` and ``rhs (B, 4)``.
    """
    li, ui, lj, uj = (np.asarray(v, dtype=float) for v in (li, ui, lj, uj))
    one = np.ones_like(li)
    coef = np.stack(
        [
            np.stack([lj, li, -one], axis=-1),
            np.stack([uj, ui, -one], axis=-1),
            np.stack([-lj, -ui, one], axis=-1),
            np.stack([-uj, -li, one], axis=-1),
        ],
        axis=-2,
    )
    rhs = np.stack([up(li * lj), up(ui * uj), -down(ui * lj), -down(li * uj)], axis=-1)
    return coef, rhs


# ----------------------------------------------------------------------------------
# Bernstein equations
# ----------------------------------------------------------------------------------
def bernstein_control_points(coeffs: np.ndarray, li, ui, lj, uj):
    """Control points of ``f`` restricted to ``[li, ui] x [lj, uj]`` and their error bound.

    Args:
        coeffs: Control points of ``f`` on the unit square, ``(dp+1, dq+1)``, or a batch
            ``(K, dp+1, dq+1)`` of same-degree polynomials.
        li, ui, lj, uj: The sub-box (inside ``[0, 1]^2``): scalars, or ``(K,)`` for a batch.

    Returns:
        ``(cp, err)``: ``cp`` shaped like ``coeffs`` and ``err`` (scalar, or ``(K,)``) with
        ``|cp - exact| <= err`` entrywise.
    """
    coeffs = np.asarray(coeffs, dtype=float)
    dp, dq = coeffs.shape[-2] - 1, coeffs.shape[-1] - 1
    su = subdivision_matrix(dp, li, ui)
    sv_t = np.swapaxes(subdivision_matrix(dq, lj, uj), -1, -2)
    cp = su @ coeffs @ sv_t
    mag = np.max(np.abs(su) @ np.abs(coeffs) @ np.abs(sv_t), axis=(-2, -1))
    return cp, up(8.0 * (dp + dq + 4) * EPS * mag + TINY)


def _control_grid(coeffs, li, ui, lj, uj):
    """Points ``c_pq (m, 3)`` of eq. 33 and per-coordinate error bounds ``(3,)``."""
    cp, err_b = bernstein_control_points(coeffs, li, ui, lj, uj)
    if cp.shape[0] == 1:  # degree elevation 0 -> 1: same polynomial, grid spans [li, ui]
        cp = np.repeat(cp, 2, axis=0)
    if cp.shape[1] == 1:
        cp = np.repeat(cp, 2, axis=1)
    dp, dq = cp.shape[0] - 1, cp.shape[1] - 1
    gx = li + (np.arange(dp + 1) / dp) * (ui - li)
    gy = lj + (np.arange(dq + 1) / dq) * (uj - lj)
    gx[-1], gy[-1] = ui, uj
    px, py = np.meshgrid(gx, gy, indexing="ij")
    points = np.stack([px.ravel(), py.ravel(), cp.ravel()], axis=1)
    err = np.array([4 * EPS * (abs(li) + abs(ui)), 4 * EPS * (abs(lj) + abs(uj)), err_b]) + TINY
    return points, err


def _hull_normals(q: np.ndarray, options: str | None) -> np.ndarray:
    """Outward facet normals of the convex hull of ``q (m, dim)`` (Qhull)."""
    hull = ConvexHull(q, qhull_options=options) if options else ConvexHull(q)
    return hull.equations[:, :-1]


def _try_hull(q: np.ndarray) -> np.ndarray | None:
    for options in (None, "QJ"):
        try:
            return _hull_normals(q, options)
        except (QhullError, ValueError):
            continue
    return None


def hull_directions(points: np.ndarray) -> np.ndarray:
    """Directions ``a (r, 3)`` whose rows ``a . x <= max a . c`` describe ``conv(points)``.

    Works in coordinates normalised by the points' extent; degenerate sets fall back to
    lower-dimensional hulls (see module docstring).  The directions need not be exact.
    """
    centre = points.mean(axis=0)
    extent = points.max(axis=0) - points.min(axis=0)
    noise = 1e3 * EPS * np.max(np.abs(points), axis=0) + 1e-290  # rounding-level extents are flat
    scale = np.where(extent > noise, extent, 1.0)
    q = (points - centre) / scale
    _, sv, vt = np.linalg.svd(q, full_matrices=True)
    # q has unit extent along every non-flat axis; singular values at the level of the
    # (normalised) rounding noise are flat directions too.
    tol = max(_RANK_TOL, 10.0 * np.sqrt(len(points)) * float(np.max(noise / scale)))
    rank = int(np.sum(sv > tol))
    normals = None
    if rank == 3:
        normals = _try_hull(q)
        rank = 2 if normals is None else 3
    if rank == 2:
        planar = _try_hull(q @ vt[:2].T)
        if planar is not None:
            normals = np.vstack([planar @ vt[:2], vt[2], -vt[2]])
        else:
            rank = 1
    if rank == 1:
        normals = np.vstack([vt, -vt])
    if rank == 0:
        normals = np.vstack([np.eye(3), -np.eye(3)])
    # Merge (nearly) coplanar facets in the normalised coordinates, where a change of
    # 1e-9 in a unit normal loosens its row by at most ~1e-9 of the points' extent.
    normals = np.unique(np.round(normals / np.linalg.norm(normals, axis=1, keepdims=True), 9), axis=0)
    directions = normals * (scale.min() / scale)  # = normals / scale, up to a positive factor
    size = np.max(np.abs(directions), axis=1, keepdims=True)
    keep = (size[:, 0] > 0) & np.all(np.isfinite(directions), axis=1)
    return directions[keep] / size[keep]


def bernstein_relaxation(coeffs: np.ndarray, li: float, ui: float, lj: float, uj: float):
    """Rows enclosing ``x_k = f(x_i, x_j)`` on ``[li, ui] x [lj, uj]``.

    Args:
        coeffs: ``f``'s control points on the unit square, ``(dp+1, dq+1)``.
        li, ui, lj, uj: The sub-box, inside ``[0, 1]^2``.

    Returns:
        ``coef (r, 3)`` over ``(x_i, x_j, x_k)`` and ``rhs (r,)``, valid with rounding.
    """
    points, err = _control_grid(coeffs, float(li), float(ui), float(lj), float(uj))
    a = hull_directions(points)
    dots = points @ a.T  # (m, r)
    dot_err = 2 * EPS * (np.abs(points) @ np.abs(a).T).max(axis=0)
    pad = np.abs(a) @ err + dot_err + TINY
    rhs = up(up(dots.max(axis=0)) + up(2.0 * pad))
    return a, rhs


# ----------------------------------------------------------------------------------
# All rows of a System
# ----------------------------------------------------------------------------------
def relaxation_rows(
    system: System, lower: np.ndarray, upper: np.ndarray, *, midpoint_tangent: bool = True,
    rotations: RotationStructure | None = None, cut_points: np.ndarray | None = None, quaternion: bool = True,
    limits: bool = True,
) -> tuple[sp.csr_matrix, np.ndarray]:  # fmt: skip
    """All relaxation rows of ``system``'s Psi equations on the box ``[lower, upper]``.

    Args:
        system: The canonical system.
        lower, upper: The box, shape ``(n,)``, finite.
        midpoint_tangent: Passed to :func:`square_relaxation`.
        rotations: The system's rotations and joint limits (:mod:`.rotation_cuts`).  With
            ``quaternion``, adds their quaternion-box rows (:func:`.rotation_cuts.rotation_rows`)
            and the eigenvector cuts at ``cut_points``; with ``limits``, the ball rows of the
            joint limits (:func:`.rotation_cuts.limit_rows`) and their cuts at ``cut_points``.
        cut_points: ``(P, n)`` points to separate (e.g. LP optima of an earlier pass).

    Returns:
        ``(G_rel, h_rel)``: sparse ``(r, n)`` and ``(r,)`` with ``G_rel x <= h_rel`` for every
        solution of the Psi equations in the box (and the chord cuts of its angle
        couplings, :func:`.couplings.coupling_rows`; and the rotation cuts).
    """
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    blocks = []  # (cols (B, c), coef (B, r, c), rhs (B, r))
    if len(system.squares):
        k, i = system.squares.T
        coef, rhs = square_relaxation(lower[i], upper[i], midpoint_tangent)
        blocks.append((np.stack([i, k], axis=1), coef, rhs))
    if len(system.products):
        k, i, j = system.products.T
        coef, rhs = product_relaxation(lower[i], upper[i], lower[j], upper[j])
        blocks.append((np.stack([i, j, k], axis=1), coef, rhs))
    for eq in system.bernstein:
        coef, rhs = bernstein_relaxation(eq.coeffs, lower[eq.i], upper[eq.i], lower[eq.j], upper[eq.j])
        blocks.append((np.array([[eq.i, eq.j, eq.k]]), coef[None], rhs[None]))
    chords = coupling_rows(system.couplings, lower, upper)
    if chords is not None:
        blocks.append(chords)
    blocks.extend(_rotation_blocks(rotations, lower, upper, cut_points, quaternion, limits))
    return _assemble(blocks, system.n)


def _rotation_blocks(rotations: RotationStructure | None, lower, upper, cut_points, quaternion: bool, limits: bool):
    if rotations is None:
        return []
    blocks = []
    if quaternion:
        blocks.append(rotation_rows(rotations.rotations, lower, upper))
        if cut_points is not None:
            blocks.append(eigen_cuts(rotations.rotations, cut_points))
    if limits:
        blocks.append(limit_rows(rotations))
        if cut_points is not None:
            blocks.append(limit_cuts(rotations, cut_points))
    return [b for b in blocks if b is not None]


def _assemble(blocks, n: int) -> tuple[sp.csr_matrix, np.ndarray]:
    rows, cols, vals, rhs_all = [], [], [], []
    offset = 0
    for cols_b, coef, rhs in blocks:
        nb, r, c = coef.shape
        row_ids = offset + np.arange(nb * r).reshape(nb, r)
        rows.append(np.repeat(row_ids[:, :, None], c, axis=2).ravel())
        cols.append(np.repeat(cols_b[:, None, :], r, axis=1).ravel())
        vals.append(coef.ravel())
        rhs_all.append(rhs.ravel())
        offset += nb * r
    if not blocks:
        return sp.csr_matrix((0, n)), np.zeros(0)
    G = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(offset, n)
    )
    G.eliminate_zeros()
    return G, np.concatenate(rhs_all)
