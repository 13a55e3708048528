"""The affine forms of the pair test's two sides over boxes, and interval bounds read from them.

The hand side (a function of the pair's joint angles): ``d = c_b - c_a`` between the
fingertip centres (hand points) and, per side, the cap's axis (the point's normal), in
the frame of the links' common ancestor.  The object side (a function of the object
regions' parameters): ``d`` with ``c = o + r nu`` and the contact normals ``h = -nu``, in
the object frame.  Every form is a first-order Taylor expansion at the box's centre with
a remainder from bounds on the second derivatives (:mod:`.affine`).
"""

from __future__ import annotations

import numpy as np

from ..region_kinds import local_remainders
from . import affine as af
from .problem import PairProblem

__all__ = ["hand_forms", "object_forms", "norm_upper", "interval", "length_bounds", "vector_spread", "axial_bounds",
           "half_width_upper", "dihedral_bounds"]  # fmt: skip


def hand_forms(pp: PairProblem, zc: np.ndarray, half: np.ndarray) -> tuple[af.Form, list[af.Form]]:
    """``d = c_b - c_a`` and, per side, the cap's axis or the point's normal (common link frame)."""
    B, K = zc.shape
    sa = pp.slices[0]
    d, J, Ra, Wa, Rb, Wb = pp.kin.evaluate(zc[:, sa])
    curv = np.zeros((K, K))
    curv[sa, sa] = pp.kin.problem.curvature_mm
    Jfull = np.zeros((B, 3, K))
    Jfull[:, :, sa] = -J
    directions = []
    for side, (R, W) in enumerate(((Ra, Wa), (Rb, Wb))):
        v = np.einsum("bij,j->bi", R, pp.tips[side].direction)
        Jv = np.zeros((B, 3, K))
        Jv[:, :, sa] = np.cross(W, v[:, :, None], axis=1)
        M = np.zeros((K, K))
        M[sa, sa] = pp.kin.rotation_curvature[side]
        directions.append(af.taylor_vector(v, Jv, half, M))
    return af.taylor_vector(-d, Jfull, half, curv), directions


def object_forms(pp: PairProblem, zc: np.ndarray, half: np.ndarray, *, local: bool = True) -> tuple[af.Form, af.Form, af.Form]:  # fmt: skip
    """``d = c_b - c_a`` with ``c = o + r nu``, ``h_a = -nu_a``, ``h_b = -nu_b`` (object frame).

    The remainders of Bézier regions come from the patch's nets over each box
    (:func:`~..region_kinds.local_remainders`) when ``local``, else from the whole patch's bounds
    (:func:`~..region_kinds.region_curvature`): ~1 ms more per batch, which the object side's searches
    repay many times (guitar-tuning's key: the distance floor within 0.01 mm in 8,000 boxes
    instead of 1.1 mm short after 20,000) but the product test of :func:`.product.prove_pair_infeasible`,
    whose boxes are set by the joint angles, does not (guitar-holding's pair test: +0.6 s)."""
    B, K = zc.shape
    centres, normals = [], []
    for side in (0, 1):
        (region, (m_point, m_normal)), radius = pp.objects[side], pp.hand[side][1]
        sl = pp.slices[1 + side]
        o, nu = region.evaluate(zc[:, sl])
        do, dnu = region.jacobian(zc[:, sl])
        reach = half[:, sl].sum(axis=1)
        Jc, Jn = np.zeros((B, 3, K)), np.zeros((B, 3, K))
        Jc[:, :, sl], Jn[:, :, sl] = (do + radius * dnu) * half[:, None, sl], -dnu * half[:, None, sl]
        r_point, r_normal = 0.5 * m_point * reach**2, 0.5 * m_normal * reach**2
        if local and half[:, sl].any():  # None: no patch (its whole domain's bounds are as tight), or |N| may vanish
            tight = local_remainders(region, zc[:, sl] - half[:, sl], zc[:, sl] + half[:, sl])
            if tight is not None:
                r_point, r_normal = np.minimum(r_point, tight[0]), np.minimum(r_normal, tight[1])
        centres.append(af.Form(o + radius * nu, Jc, r_point + radius * r_normal))
        normals.append(af.Form(-nu, Jn, r_normal))
    return af.sub(centres[1], centres[0]), normals[0], normals[1]


def norm_upper(v: af.Form) -> np.ndarray:
    """An upper bound of ``|v|`` over the box (B,)."""
    return np.linalg.norm(v.c, axis=1) + np.linalg.norm(v.A, axis=1).sum(axis=1) + v.rho


# -- the twist about the line between the fingertip centres -----------------------------------------
def interval(f: af.Form) -> tuple[np.ndarray, np.ndarray]:
    s = af.spread(f)
    return f.c - s, f.c + s


def _mul(a: tuple, b: tuple) -> tuple[np.ndarray, np.ndarray]:
    p = np.stack([a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]])
    return p.min(axis=0), p.max(axis=0)


def length_bounds(d: af.Form) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``|d|`` over the boxes (B,), (B,): ``|c|`` less and plus the form's spread."""
    lower = np.maximum(np.linalg.norm(d.c, axis=1) - np.linalg.norm(d.A, axis=1).sum(axis=1) - d.rho, 0.0)
    return lower, norm_upper(d)


def vector_spread(d: af.Form) -> np.ndarray:
    """``sum_k |A_k| + rho`` of a vector form: how far it strays from ``c`` over the box (B,)."""
    return np.linalg.norm(d.A, axis=1).sum(axis=1) + d.rho


def axial_bounds(d: af.Form, v: af.Form, length: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``v . d / |d|`` (clipped to [-1, 1]; ``[-1, 1]`` where ``|d|`` may be 0)."""
    lo, hi = interval(af.dot(d, v))
    ok = length[0] > 0.0
    L0, L1 = np.where(ok, length[0], 1.0), np.where(ok, length[1], 1.0)
    q = np.stack([lo / L0, lo / L1, hi / L0, hi / L1])
    return np.where(ok, np.clip(q.min(axis=0), -1.0, 1.0), -1.0), np.where(ok, np.clip(q.max(axis=0), -1.0, 1.0), 1.0)


def half_width_upper(m_ax: tuple, h_ax: tuple, beta: float) -> np.ndarray:
    """An upper bound [rad] of the half width ``w = arccos((cos beta - m_par h_par) / (|m_perp|
    |h_perp|))`` of the arc of twists ``psi`` about ``d`` that bring a unit vector ``m`` (the
    cap's axis) within ``beta`` of ``h`` (the contact normal), from bounds of their axial
    components ``m_par = m . u``, ``h_par = h . u`` (``u = d / |d|``): ``pi`` when every twist
    may do, ``-1`` when none can (B,)."""
    prod = _mul(m_ax, h_ax)
    perp = []
    for lo, hi in (m_ax, h_ax):
        sq_hi = np.maximum(lo * lo, hi * hi)
        sq_lo = np.where((lo <= 0.0) & (hi >= 0.0), 0.0, np.minimum(lo * lo, hi * hi))
        perp.append((np.sqrt(np.maximum(1.0 - sq_hi, 0.0)), np.sqrt(np.maximum(1.0 - sq_lo, 0.0))))
    D_lo, D_hi = perp[0][0] * perp[1][0], perp[0][1] * perp[1][1]
    N_lo = np.cos(beta) - prod[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(N_lo >= 0.0, N_lo / D_hi, np.where(D_lo > 0.0, N_lo / D_lo, -np.inf))
    ratio = np.where(np.isnan(ratio), -np.inf, ratio)  # 0 / 0: the cone's edge for every twist
    ratio = ratio - (1e-9 * np.abs(np.where(np.isfinite(ratio), ratio, 0.0)) + 1e-12)
    return np.where(ratio > 1.0, -1.0, np.arccos(np.clip(ratio, -1.0, 1.0)))


def dihedral_bounds(d: af.Form, x: af.Form, y: af.Form, length: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds ``(lo, hi)`` [rad] of the signed angle about ``d`` from the plane ``(d, x)`` to the
    plane ``(d, y)`` -- ``atan2(|d| d . (x cross y), (d cross x) . (d cross y))`` -- and
    whether they are known ``(B,)`` (not where both arguments may vanish)."""
    s = _mul(length, interval(af.dot(d, af.cross(x, y))))
    c = interval(af.dot(af.cross(d, x), af.cross(d, y)))
    known = ~((s[0] <= 0.0) & (s[1] >= 0.0) & (c[0] <= 0.0) & (c[1] >= 0.0))
    ref = np.arctan2(0.5 * (s[0] + s[1]), 0.5 * (c[0] + c[1]))
    corners = np.stack([np.arctan2(sv, cv) for sv in s for cv in c])
    rel = np.angle(np.exp(1j * (corners - ref)))  # the box misses 0: its corners lie within pi of ref
    return ref + rel.min(axis=0), ref + rel.max(axis=0), known
