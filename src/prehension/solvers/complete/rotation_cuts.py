r"""Cuts of the rotation group on a box: the quaternion matrix ``Z(R) = 4 q q^T`` (issue 32).

Every link rotation of the system is 9 variables ``r_ij`` (entries of ``R_object_link``,
row ``i``, column ``j``, 1-based below) with the orthonormality equations, whose
square/product relaxations are weak on wide boxes: the linear programs then narrow a box
of a many-link task by a few percent.  The convex hull of SO(3) is a spectrahedron
(Sanyal, Sottile & Sturmfels 2011; Saunderson, Parrilo & Willsky 2015): with

.. math::

    Z(R) = \begin{pmatrix}
      1 + r_{11} + r_{22} + r_{33} & r_{32} - r_{23} & r_{13} - r_{31} & r_{21} - r_{12} \\
      r_{32} - r_{23} & 1 + r_{11} - r_{22} - r_{33} & r_{12} + r_{21} & r_{13} + r_{31} \\
      r_{13} - r_{31} & r_{12} + r_{21} & 1 - r_{11} + r_{22} - r_{33} & r_{23} + r_{32} \\
      r_{21} - r_{12} & r_{13} + r_{31} & r_{23} + r_{32} & 1 - r_{11} - r_{22} + r_{33}
    \end{pmatrix},

``Z(R) = 4 q q^T`` for the unit quaternion ``q = (w, x, y, z)`` of ``R`` (either sign), and
``conv SO(3) = {R : Z(R) PSD}``.  ``Z`` is affine in ``R`` and ``trace Z = 4``.  Three kinds
of linear rows follow, all valid for every rotation in the box:

1. **Quaternion-box rows.**  The box of ``R`` bounds each entry of ``Z`` (interval
   arithmetic), and these intervals are narrowed by the identities of a rank-one
   ``4 q q^T`` (:func:`z_intervals`): ``trace Z = 4``; ``Z_ab^2 = Z_aa Z_bb`` (so
   ``|Z_ab| <= sqrt(Z_aa Z_bb)``, and ``Z_aa >= Z_ab^2 / Z_bb``); ``Z_aa Z_bc = Z_ab Z_ac``.
   They bound the quaternion: with ``a0`` the component whose ``Z_aa`` has the largest
   lower bound and, when that bound is positive, the sign of ``q`` chosen with
   ``q_a0 > 0``, ``q_a0 = sqrt(Z_a0a0) / 2`` and ``q_b = Z_a0b / (2 sqrt(Z_a0a0))``; with no
   positive lower bound, ``|q_b| <= sqrt(Z_bb) / 2``.  For each vector ``v`` of
   :data:`DIRECTIONS` (``e_a``, ``e_a +- e_b``, ``(1, +-1, +-1, +-1)``),
   ``v^T Z v = 4 (v . q)^2`` lies in ``4 [v . q]^2`` -- which is sign-free, so the choice
   of ``q``'s sign does not matter.  ``v^T Z v`` has integer coefficients in ``r``, so
   only the interval ends are rounded (outwards).  Without any box information the lower
   ends are the PSD cuts ``v^T Z v >= 0`` (e.g. ``Z_aa + Z_bb >= 2 |Z_ab|``); on small
   boxes both ends close in on the rotations of the box, like the McCormick rows of a
   product but in directions mixing the entries of ``R``.
2. The propagated intervals of the off-diagonal entries, as rows ``Z_ab in [lo, hi]``.
3. **Eigenvector cuts** (:func:`eigen_cuts`): at a point ``R*`` (an LP optimum) where
   ``Z(R*)`` has a negative eigenvalue with unit eigenvector ``v``, the row
   ``v^T Z(R) v >= 0`` separates ``R*`` from ``conv SO(3)``.  Its coefficients are
   floats computed from ``v``; each is within ``16 eps`` of the exact
   ``sum_ab v_a v_b C_ab`` and ``|r_ij| <= 1``, so the constant is padded by
   :data:`CUT_PAD` (far above ``9 x 16 eps``).

A row is emitted only when it is tighter than what the box alone gives its linear form
(``min_gain``), so wide boxes carry few rows.  Rounding: every interval operation is padded
outwards by :data:`CUT_PAD` (the numbers involved are at most 16 in magnitude); numpy's
``sqrt`` is correctly rounded.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ...system.formulation import Formulation, dof_angles

__all__ = ["CUT_PAD", "DIRECTIONS", "LIMIT_DIRECTIONS", "Z_COEFFS", "RotationStructure", "rotation_structure",
           "z_matrix", "z_intervals", "quaternion_box", "rotation_rows", "eigen_cuts", "limit_rows", "limit_cuts"]

CUT_PAD = 1e-12

#: ``Z_COEFFS[a, b]``: ``(constant, coefficients of r flattened row-major (r11, r12, ..., r33))``.
Z_COEFFS = np.zeros((4, 4, 10))


def _fill_coefficients() -> None:
    def r(i, j):  # column of r_ij (1-based) in the (constant, r...) layout
        return 1 + 3 * (i - 1) + (j - 1)

    diag_signs = ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))
    for a, signs in enumerate(diag_signs):
        Z_COEFFS[a, a, 0] = 1.0
        for k, s in enumerate(signs):
            Z_COEFFS[a, a, r(k + 1, k + 1)] = s
    off = {(0, 1): ((3, 2, 1), (2, 3, -1)), (0, 2): ((1, 3, 1), (3, 1, -1)), (0, 3): ((2, 1, 1), (1, 2, -1)),
           (1, 2): ((1, 2, 1), (2, 1, 1)), (1, 3): ((1, 3, 1), (3, 1, 1)), (2, 3): ((2, 3, 1), (3, 2, 1))}
    for (a, b), terms in off.items():
        for i, j, s in terms:
            Z_COEFFS[a, b, r(i, j)] = Z_COEFFS[b, a, r(i, j)] = s


_fill_coefficients()

#: Integer vectors ``v`` of the quaternion-box rows ``v^T Z v in 4 [v . q]^2``.
DIRECTIONS = np.array(
    [np.eye(4)[a] for a in range(4)]
    + [np.eye(4)[a] + s * np.eye(4)[b] for a, b in itertools.combinations(range(4), 2) for s in (1.0, -1.0)]
    + [np.array((1.0,) + signs) for signs in itertools.product((1.0, -1.0), repeat=3)]
)
#: ``(constant, r coefficients)`` of ``v^T Z v`` for each direction (exact small integers).
_DIRECTION_FORMS = np.einsum("va,vb,abk->vk", DIRECTIONS, DIRECTIONS, Z_COEFFS)


def z_matrix(R: np.ndarray) -> np.ndarray:
    """``Z(R)`` for rotations ``R (..., 3, 3)``: ``(..., 4, 4)``."""
    R = np.asarray(R, dtype=float)
    flat = R.reshape(R.shape[:-2] + (9,))
    return Z_COEFFS[..., 0] + np.einsum("abk,...k->...ab", Z_COEFFS[..., 1:], flat)


def _lo(x):
    return x - CUT_PAD


def _hi(x):
    return x + CUT_PAD


def _form_range(forms: np.ndarray, lo9: np.ndarray, hi9: np.ndarray):
    """Outward range of ``const + coef . r`` over the box: forms ``(..., 10)``, box ``(L, 9)``
    -> ``(L, ...)`` lower and upper ends."""
    coef = forms[..., 1:]
    lo9 = lo9.reshape((lo9.shape[0],) + (1,) * (coef.ndim - 1) + (9,))
    hi9 = hi9.reshape(lo9.shape)
    low = forms[..., 0] + np.sum(np.minimum(coef * lo9, coef * hi9), axis=-1)
    high = forms[..., 0] + np.sum(np.maximum(coef * lo9, coef * hi9), axis=-1)
    return _lo(low), _hi(high)


def _mul(al, ah, bl, bh):
    p = np.stack([al * bl, al * bh, ah * bl, ah * bh])
    return _lo(p.min(axis=0)), _hi(p.max(axis=0))


def _narrow_diagonal(zl, zh):
    """Trace 4 and ``Z_aa >= Z_ab^2 / Z_bb`` (in place, per link)."""
    d_lo, d_hi = np.diagonal(zl, axis1=1, axis2=2).copy(), np.diagonal(zh, axis1=1, axis2=2).copy()
    d_lo, d_hi = np.maximum(d_lo, 0.0), np.minimum(d_hi, 4.0)
    rest_lo = d_lo.sum(axis=1, keepdims=True) - d_lo
    rest_hi = d_hi.sum(axis=1, keepdims=True) - d_hi
    d_hi = np.minimum(d_hi, _hi(4.0 - rest_lo))
    d_lo = np.maximum(d_lo, _lo(4.0 - rest_hi))
    for a, b in itertools.permutations(range(4), 2):
        ol, oh = zl[:, a, b], zh[:, a, b]
        mag = np.where(ol > 0, ol, np.where(oh < 0, -oh, 0.0))  # least |Z_ab| when its sign is known
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = np.where(d_hi[:, b] > 0, _lo(_lo(mag * mag) / _hi(d_hi[:, b])), 0.0)
        d_lo[:, a] = np.maximum(d_lo[:, a], bound)
    idx = np.arange(4)
    zl[:, idx, idx], zh[:, idx, idx] = d_lo, d_hi


def _narrow_off_diagonal(zl, zh):
    """``|Z_ab| <= sqrt(Z_aa Z_bb)``, ``|Z_ab| >= sqrt(..)`` with known sign, ``Z_bc = Z_ab Z_ac / Z_aa``."""
    d_lo, d_hi = np.diagonal(zl, axis1=1, axis2=2), np.diagonal(zh, axis1=1, axis2=2)
    for a, b in itertools.combinations(range(4), 2):
        cap = _hi(np.sqrt(_hi(d_hi[:, a] * d_hi[:, b])))
        floor = _lo(np.sqrt(np.maximum(_lo(d_lo[:, a] * d_lo[:, b]), 0.0)))
        ol, oh = np.maximum(zl[:, a, b], -cap), np.minimum(zh[:, a, b], cap)
        ol = np.where(ol >= 0, np.maximum(ol, floor), ol)
        oh = np.where(oh <= 0, np.minimum(oh, -floor), oh)
        zl[:, a, b] = zl[:, b, a] = ol
        zh[:, a, b] = zh[:, b, a] = oh
    for a in range(4):
        others = [b for b in range(4) if b != a]
        pos = _lo(d_lo[:, a]) > 0  # the padded end divides: it must be positive too
        if not np.any(pos):
            continue
        for b, c in itertools.combinations(others, 2):
            pl, ph = _mul(zl[:, a, b], zh[:, a, b], zl[:, a, c], zh[:, a, c])
            with np.errstate(divide="ignore", invalid="ignore"):
                ql, qh = _mul(pl, ph, 1.0 / _hi(d_hi[:, a]), 1.0 / _lo(d_lo[:, a]))
            ql = np.where(pos & np.isfinite(ql), ql, -np.inf)
            qh = np.where(pos & np.isfinite(qh), qh, np.inf)
            zl[:, b, c] = zl[:, c, b] = np.maximum(zl[:, b, c], ql)
            zh[:, b, c] = zh[:, c, b] = np.minimum(zh[:, b, c], qh)


def z_intervals(lo9: np.ndarray, hi9: np.ndarray, rounds: int = 2):
    """Intervals ``(zl, zh) (L, 4, 4)`` enclosing ``Z(R)`` for every rotation ``R`` in each box
    ``[lo9, hi9] (L, 9)`` (row-major entries).  An empty interval (``zl > zh``) proves that
    the box holds no rotation."""
    lo9, hi9 = np.atleast_2d(np.asarray(lo9, dtype=float)), np.atleast_2d(np.asarray(hi9, dtype=float))
    zl, zh = _form_range(Z_COEFFS, lo9, hi9)
    for _ in range(rounds):
        _narrow_diagonal(zl, zh)
        _narrow_off_diagonal(zl, zh)
    return zl, zh


def quaternion_box(zl: np.ndarray, zh: np.ndarray):
    """Intervals ``(ql, qh) (L, 4)`` holding, for each box, one of ``+-q`` of every rotation
    whose ``Z`` lies in ``[zl, zh]`` (see the module docstring)."""
    d_lo = np.maximum(np.diagonal(zl, axis1=1, axis2=2), 0.0)
    d_hi = np.maximum(np.diagonal(zh, axis1=1, axis2=2), 0.0)
    half_hi = _hi(0.5 * np.sqrt(d_hi))
    ql, qh = -half_hi, half_hi.copy()
    rows = np.arange(len(zl))
    a0 = np.argmax(d_lo, axis=1)
    s_lo = _lo(2.0 * np.sqrt(d_lo[rows, a0]))  # 4 q_a0 = 2 sqrt(Z_a0a0) in [s_lo, s_hi]
    anchored = s_lo > 0  # the padded end divides: it must be positive
    s_hi = _hi(2.0 * np.sqrt(d_hi[rows, a0]))
    with np.errstate(divide="ignore", invalid="ignore"):
        for b in range(4):
            bl, bh = _mul(zl[rows, a0, b], zh[rows, a0, b], 1.0 / _hi(s_hi), 1.0 / _lo(s_lo))
            bl = np.where(anchored & np.isfinite(bl), bl, -np.inf)
            bh = np.where(anchored & np.isfinite(bh), bh, np.inf)
            ql[:, b], qh[:, b] = np.maximum(ql[:, b], bl), np.minimum(qh[:, b], bh)
    ql[rows[anchored], a0[anchored]] = np.maximum(ql[rows[anchored], a0[anchored]], _lo(0.25 * s_lo[anchored]))
    return ql, qh


def _square_range(lo, hi):
    """Outward range of ``x^2`` for ``x in [lo, hi]``."""
    top = _hi(np.maximum(lo * lo, hi * hi))
    bottom = np.where((lo > 0) | (hi < 0), _lo(np.minimum(lo * lo, hi * hi)), 0.0)
    return np.maximum(bottom, 0.0), top


def rotation_rows(rotations: np.ndarray, lower: np.ndarray, upper: np.ndarray, min_gain: float = 1e-9):
    """Quaternion-box rows of every link rotation on the box, as a relaxation block.

    Args:
        rotations: ``(L, 3, 3)`` variable indices of the links' ``R_object_link``.
        lower, upper: The box ``(n,)``.
        min_gain: A row is kept only when it beats the box's own range of its form by more.

    Returns:
        ``(cols (B, 9), coef (B, 1, 9), rhs (B, 1))`` with ``coef @ x[cols] <= rhs``, or None.
    """
    cols9 = np.asarray(rotations, dtype=int).reshape(-1, 9)
    if not len(cols9):
        return None
    lo9, hi9 = lower[cols9], upper[cols9]
    zl, zh = z_intervals(lo9, hi9)
    ql, qh = quaternion_box(zl, zh)
    dot_lo = np.sum(np.minimum(DIRECTIONS * ql[:, None, :], DIRECTIONS * qh[:, None, :]), axis=-1)
    dot_hi = np.sum(np.maximum(DIRECTIONS * ql[:, None, :], DIRECTIONS * qh[:, None, :]), axis=-1)
    sq_lo, sq_hi = _square_range(_lo(dot_lo), _hi(dot_hi))
    forms = [_DIRECTION_FORMS]
    ends_lo, ends_hi = [_lo(4.0 * sq_lo)], [_hi(4.0 * sq_hi)]  # (L, V)
    iu = np.triu_indices(4, 1)
    forms.append(Z_COEFFS[iu])
    ends_lo.append(zl[:, iu[0], iu[1]])
    ends_hi.append(zh[:, iu[0], iu[1]])
    forms = np.concatenate(forms)  # (F, 10)
    ends_lo, ends_hi = np.concatenate(ends_lo, axis=1), np.concatenate(ends_hi, axis=1)
    box_lo, box_hi = _form_range(forms, lo9, hi9)  # (L, F)
    out_cols, out_coef, out_rhs = [], [], []
    for sign, end, box_end in ((1.0, ends_hi, box_hi), (-1.0, ends_lo, box_lo)):
        gain = sign * (box_end - end)
        link, f = np.nonzero(np.isfinite(end) & (gain > min_gain))
        out_cols.append(cols9[link])
        out_coef.append(sign * forms[f, 1:])
        out_rhs.append(sign * (end[link, f] - forms[f, 0]))
    cols = np.concatenate(out_cols)
    if not len(cols):
        return None
    # the constant is an integer (exact); end - constant is rounded once more outwards
    rhs = np.concatenate(out_rhs) + CUT_PAD
    return cols, np.concatenate(out_coef)[:, None, :], rhs[:, None]


def eigen_cuts(rotations: np.ndarray, points: np.ndarray, per_link: int = 2, min_violation: float = 1e-7):
    """Eigenvector cuts ``v^T Z(R) v >= 0`` separating ``points`` from ``conv SO(3)``.

    Args:
        rotations: ``(L, 3, 3)`` variable indices.
        points: ``(P, n)`` points (e.g. LP optima).
        per_link: At most this many cuts per link (the most violated first).
        min_violation: Only eigenvalues below ``-min_violation`` give a cut.

    Returns:
        A relaxation block ``(cols (B, 9), coef (B, 1, 9), rhs (B, 1))`` or None.
    """
    cols9 = np.asarray(rotations, dtype=int).reshape(-1, 9)
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if not len(cols9) or not len(points):
        return None
    R = points[:, cols9].reshape(len(points), len(cols9), 3, 3)
    values, vectors = np.linalg.eigh(z_matrix(R))  # (P, L, 4), (P, L, 4, 4)
    least, v = values[..., 0], vectors[..., :, 0]
    out_cols, out_coef, out_rhs = [], [], []
    for link in range(len(cols9)):
        order = np.argsort(least[:, link], kind="stable")[:per_link]
        for p in order[least[order, link] < -min_violation]:
            w = v[p, link]
            form = np.einsum("a,b,abk->k", w, w, Z_COEFFS)
            out_cols.append(cols9[link])
            out_coef.append(-form[1:])
            out_rhs.append(form[0] + 16.0 * CUT_PAD)
    if not out_cols:
        return None
    return np.array(out_cols), np.array(out_coef)[:, None, :], np.array(out_rhs)[:, None]


# ----------------------------------------------------------------------------------
# Joint limits as balls: |R_a x_a - R_b x_b| <= rho
# ----------------------------------------------------------------------------------
#: Unit directions ``d`` of the static limit rows: the 13 axes of a cube (faces, edges,
#: corners), both signs; their rows describe a polytope within 1.2 times the ball.
LIMIT_DIRECTIONS = np.array(
    [s * np.array(v) / np.linalg.norm(v) for v in
     [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1),
      (1, 1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1)] for s in (1.0, -1.0)]
)


@dataclass(frozen=True, eq=False)
class RotationStructure:
    """The rotations of a system and its joint limits as balls (see :func:`rotation_structure`).

    Attributes:
        rotations: ``(L, 3, 3)`` variable indices of the links' ``R_object_link``.
        limit_cols: ``(J, 18)`` the rotation entries of the two links of each limited angle
            (link ``a``'s 9 row-major, then link ``b``'s).
        limit_vectors: ``(J, 2, 3)`` ``x_a`` (in link ``a``'s frame) and ``x_b`` (link ``b``).
        limit_radius: ``(J,)`` ``rho``: ``|R_a x_a - R_b x_b| <= rho`` at every solution.
    """

    rotations: np.ndarray
    limit_cols: np.ndarray
    limit_vectors: np.ndarray
    limit_radius: np.ndarray


def rotation_structure(form: Formulation) -> RotationStructure:
    r"""The rotations of ``form`` and the ball form of each joint-angle limit.

    The system writes an angle as ``cos = A . B``, ``sin = P . B`` (``P = R_a (w x a)``)
    or ``sin = A . Q`` (``Q = R_b (b x w)``), with ``A = R_a a``, ``B = R_b b``, and its
    limit as ``c cos + s sin >= cos h`` (``c, s`` the cosine and sine of the range's
    middle).  That is ``M . N >= cos h`` with ``M = R_a x_a``, ``N = R_b x_b``:
    ``x_a = c a + s (w x a)``, ``x_b = b`` in the first case, ``x_a = a``,
    ``x_b = c b + s (b x w)`` in the second.  Rotations keep lengths, so

    .. math::

        |R_a x_a - R_b x_b|^2 = |x_a|^2 + |x_b|^2 - 2 M . N \le |x_a|^2 + |x_b|^2 - 2 \cos h = \rho^2,

    a convex (ball) constraint, linear in the rotation entries along any direction ``d``:
    ``d . (R_a x_a - R_b x_b) <= |d| rho``.  The system's own limit row is bilinear in the
    entries (McCormick products), which says nothing while the rotations are wide.
    """
    rotations = np.reshape(list(form.R_object_link.values()), (-1, 3, 3))
    cols, vectors, radius = [], [], []
    joints = [j for j in form.task.hand.joints if j.parent in form.R_object_link and j.child in form.R_object_link]
    for joint in joints:
        for ang in dof_angles(joint):
            if ang.dof not in form.dof_vars or not ang.half_range < np.pi:
                continue
            c, s = np.cos(ang.mid), np.sin(ang.mid)
            if ang.link_w == ang.link_a:
                xa, xb = c * ang.a + s * np.cross(ang.w, ang.a), np.asarray(ang.b, dtype=float)
            else:
                xa, xb = np.asarray(ang.a, dtype=float), c * ang.b + s * np.cross(ang.b, ang.w)
            rho2 = xa @ xa + xb @ xb - 2.0 * np.cos(ang.half_range)
            cols.append(np.concatenate([form.R_object_link[ang.link_a].ravel(), form.R_object_link[ang.link_b].ravel()]))
            vectors.append((xa, xb))
            radius.append(np.sqrt(max(rho2, 0.0) + 1e-9))  # the pad covers every rounding above
    return RotationStructure(rotations, np.array(cols, dtype=int).reshape(-1, 18),
                             np.array(vectors, dtype=float).reshape(-1, 2, 3), np.array(radius, dtype=float))


def _limit_block(structure: RotationStructure, joint: np.ndarray, d: np.ndarray):
    """Rows ``d . (R_a x_a - R_b x_b) <= |d| rho`` for ``joint (K,)``, unit ``d (K, 3)``."""
    xa, xb = structure.limit_vectors[joint, 0], structure.limit_vectors[joint, 1]
    coef = np.concatenate([np.einsum("ki,kj->kij", d, xa).reshape(-1, 9),
                           -np.einsum("ki,kj->kij", d, xb).reshape(-1, 9)], axis=1)  # (K, 18)
    rhs = structure.limit_radius[joint] * (1.0 + 1e-12) + CUT_PAD * (1.0 + np.abs(coef).sum(axis=1))
    return structure.limit_cols[joint], coef[:, None, :], rhs[:, None]


def limit_rows(structure: RotationStructure):
    """The static limit rows (:data:`LIMIT_DIRECTIONS`) of every limited angle, or None."""
    n = len(structure.limit_radius)
    if not n:
        return None
    joint = np.repeat(np.arange(n), len(LIMIT_DIRECTIONS))
    return _limit_block(structure, joint, np.tile(LIMIT_DIRECTIONS, (n, 1)))


def limit_cuts(structure: RotationStructure, points: np.ndarray, per_joint: int = 2, min_violation: float = 1e-7):
    """Limit rows along ``(M* - N*) / |M* - N*|`` at points where ``|M* - N*| > rho``."""
    n = len(structure.limit_radius)
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if not n or not len(points):
        return None
    entries = points[:, structure.limit_cols]  # (P, J, 18)
    ra, rb = entries[..., :9].reshape(len(points), n, 3, 3), entries[..., 9:].reshape(len(points), n, 3, 3)
    gap = np.einsum("pjik,jk->pji", ra, structure.limit_vectors[:, 0]) - np.einsum(
        "pjik,jk->pji", rb, structure.limit_vectors[:, 1])  # (P, J, 3)
    length = np.linalg.norm(gap, axis=-1)
    joints, dirs = [], []
    for j in range(n):
        order = np.argsort(-length[:, j], kind="stable")[:per_joint]
        for p in order[length[order, j] > structure.limit_radius[j] + min_violation]:
            joints.append(j)
            dirs.append(gap[p, j] / length[p, j])
    if not joints:
        return None
    return _limit_block(structure, np.array(joints), np.array(dirs))
