"""The force-closure prune: a certificate that no configuration of a box is force closure.

With ``require="force-closure"`` the complete solver looks for force-closure grasps only
(:func:`prehension.quality.grasp_quality` with the stated friction model); a box is then
discarded when this module proves that *no* configuration in it can be force closure.

**The certificate.**  A grasp is force closure when its primitive wrenches ``w_k``
(:mod:`prehension.quality.wrenches`: per contact, the edges of its linearised friction
cone and, for soft fingers, two torsion generators) positively span ``R^6``.  If some
direction ``w = (a, b)`` has ``w . w_k < 0`` for every ``k``, they lie in an open half
space and cannot.  For a contact at ``p`` with inward unit normal ``n`` (object frame),
every force ``f`` of its *full* Coulomb cone (which holds the inscribed pyramid's edges),
normal component 1, gives

.. math::

    w \\cdot \\big(f, (p - c) \\times f / \\rho\\big) = f \\cdot g, \\qquad
    g = a + b \\times (p - c) / \\rho, \\qquad
    \\max_{f} f \\cdot g = n \\cdot g + \\mu\\, |n \\times g|,

and a torsion generator gives ``n . g +- gamma (b . n) / rho``.  Over a box the complete
solver encloses each contact's object point ``p`` (the control net of the sub-patch its
``(s, t)`` interval cuts from a Bézier patch -- the convex-hull property --, the cap's
centre plus its radius times the normal interval, or a fixed point) and its unit outward
normal (the box's interval of ``nu``; constant for a point region).  Interval arithmetic
then bounds, for every ``p`` and unit ``n`` of those enclosures,

.. math::

    \\sup\\big(n \\cdot g\\big) + \\mu \\sup |n \\times g| \\;\\le\\; -\\delta
    \\quad\\text{and, soft fingers,}\\quad
    \\sup\\big(n \\cdot g\\big) + \\frac{\\gamma}{\\rho} \\sup|b \\cdot n| \\;\\le\\; -\\delta

for every contact, ``|w|_inf = 1``, ``delta = CERTIFICATE_MARGIN`` (1e-6, far above
rounding: the bounds are sums of a few dozen O(1) products): then every configuration of
the box has every primitive wrench at least ``delta`` inside the half space, so the
force-closure LP (``sum lambda_k w_k = 0``, ``lambda_k >= t* > 0``) is infeasible for each.
The test is *sound*: the enclosures contain every configuration's contacts, so a box with
a force-closure configuration is never discarded.  It is not complete: a box whose
certificate fails is split, and smaller boxes have tighter enclosures.

**Finding ``w``.**  A linear program (HiGHS through :func:`scipy.optimize.linprog`) at
sample contacts of the box -- its centre, then also the corners of the point and normal
enclosures -- with each cone replaced by a circumscribed pyramid of 16 edges: maximise
``s`` subject to ``w . w_k + s <= 0``, ``|w|_inf <= 1``.  Only a ``w`` that the interval
bound above then certifies counts; the LP only proposes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from ...geometry.rotations import orthonormal_frame
from ...quality import QualityOptions, torque_reference
from ...system.formulation import Formulation
from .region_kinds import object_point_normal_box

__all__ = ["ClosureCertificate", "CERTIFICATE_MARGIN", "closure_prune", "contact_enclosures", "certified_bound"]

CERTIFICATE_MARGIN = 1e-6  # the largest w . wrench a certificate allows (|w|_inf = 1; wrenches are O(1))
_SAMPLE_EDGES = 16  # edges of the circumscribed pyramid the LP samples each cone with


@dataclass(frozen=True)
class ClosureCertificate:
    """A proof that no configuration of a box is force closure.

    Attributes:
        direction: (6,) ``w = (a, b)``, ``|w|_inf = 1``: every primitive wrench of every
            configuration of the box has ``w . wrench <= -margin``.
        margin: ``-`` the certified upper bound of ``w . wrench`` over the box (>= CERTIFICATE_MARGIN).
    """

    direction: np.ndarray
    margin: float


def contact_enclosures(form: Formulation, lower, upper) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Boxes holding every contact's object point [mm] and unit *outward* normal (object frame)
    for every configuration of the box ``[lower, upper]``: ``(p_lo, p_hi, nu_lo, nu_hi)``, each (C, 3)."""
    task = form.task
    C = len(task.contacts)
    p_lo, p_hi, nu_lo, nu_hi = (np.zeros((C, 3)) for _ in range(4))
    for ci, (contact, cv) in enumerate(zip(task.contacts, form.contact_vars)):
        p_lo[ci], p_hi[ci], nu_lo[ci], nu_hi[ci] = object_point_normal_box(task.object_region(contact), cv, lower, upper)
    return p_lo, p_hi, nu_lo, nu_hi


def closure_prune(form: Formulation, lower, upper, quality: QualityOptions) -> ClosureCertificate | None:
    """A certificate that no configuration of the box is force closure, or ``None`` (module docstring)."""
    p_lo, p_hi, nu_lo, nu_hi = contact_enclosures(form, lower, upper)
    if np.any(np.all((nu_lo <= 0.0) & (nu_hi >= 0.0), axis=1)):
        return None  # a contact's normal may point anywhere: no half space can hold its cone
    centre, rho = torque_reference(form.task, quality)
    for samples in (_centre_samples, _corner_samples):
        w = _separating_direction(*samples(p_lo, p_hi, nu_lo, nu_hi), centre, rho, quality)
        if w is None:
            return None  # not even the samples can be separated: the box may hold force closure
        bound = certified_bound(w, p_lo, p_hi, -nu_hi, -nu_lo, centre, rho, quality)
        if bound <= -CERTIFICATE_MARGIN:
            return ClosureCertificate(w, -bound)
    return None


def certified_bound(w, p_lo, p_hi, n_lo, n_hi, centre, rho: float, quality: QualityOptions) -> float:
    """An upper bound of ``w . wrench`` over every primitive wrench of every contact at a
    point of ``[p_lo, p_hi]`` with an inward unit normal in ``[n_lo, n_hi]`` ((C, 3) each),
    by interval arithmetic (module docstring)."""
    a, b = np.asarray(w[:3], float), np.asarray(w[3:], float)
    r_lo, r_hi = p_lo - centre, p_hi - centre  # (C, 3)
    bxr_lo, bxr_hi = _cross_const_interval(b, r_lo, r_hi)
    g_lo, g_hi = a + bxr_lo / rho, a + bxr_hi / rho  # (C, 3): g = a + b x r / rho
    ng = _dot_interval(n_lo, n_hi, g_lo, g_hi)[1]  # (C,) sup n . g
    c_lo, c_hi = _cross_interval(n_lo, n_hi, g_lo, g_hi)
    tangential = np.sqrt(np.sum(np.maximum(np.abs(c_lo), np.abs(c_hi)) ** 2, axis=1))  # sup |n x g|
    worst = ng + quality.friction * tangential
    if quality.torsion_mm > 0:
        bn_lo, bn_hi = _dot_interval(n_lo, n_hi, np.broadcast_to(b, n_lo.shape), np.broadcast_to(b, n_lo.shape))
        worst = np.maximum(worst, ng + quality.torsion_mm / rho * np.maximum(np.abs(bn_lo), np.abs(bn_hi)))
    return float(np.max(worst))


# -- interval arithmetic on (C, 3) boxes ------------------------------------------------------
def _mul_interval(a_lo, a_hi, b_lo, b_hi):
    products = np.stack([a_lo * b_lo, a_lo * b_hi, a_hi * b_lo, a_hi * b_hi])
    return products.min(axis=0), products.max(axis=0)


def _dot_interval(a_lo, a_hi, b_lo, b_hi):
    lo, hi = _mul_interval(a_lo, a_hi, b_lo, b_hi)
    return lo.sum(axis=-1), hi.sum(axis=-1)


def _cross_interval(a_lo, a_hi, b_lo, b_hi):
    """``a x b`` of interval vectors (C, 3), each component from its two products."""
    lo, hi = np.empty_like(a_lo), np.empty_like(a_lo)
    for k, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
        p_lo, p_hi = _mul_interval(a_lo[:, i], a_hi[:, i], b_lo[:, j], b_hi[:, j])
        q_lo, q_hi = _mul_interval(a_lo[:, j], a_hi[:, j], b_lo[:, i], b_hi[:, i])
        lo[:, k], hi[:, k] = p_lo - q_hi, p_hi - q_lo
    return lo, hi


def _cross_const_interval(b, r_lo, r_hi):
    """``b x r`` for a fixed vector ``b`` (3,) and interval vectors ``r`` (C, 3)."""
    B = np.broadcast_to(b, r_lo.shape)
    return _cross_interval(B, B, r_lo, r_hi)


# -- proposing w ------------------------------------------------------------------------------
def _centre_samples(p_lo, p_hi, nu_lo, nu_hi):
    return 0.5 * (p_lo + p_hi)[:, None], _unit(-0.5 * (nu_lo + nu_hi))[:, None]  # (C, 1, 3) each


def _corner_samples(p_lo, p_hi, nu_lo, nu_hi):
    """The centre, the 8 corners of the point box (centre normal) and the 8 corners of the
    normal box (normalised; centre point): (C, 17, 3) points and inward normals."""
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)  # (8, 3)
    p_mid, n_mid = _centre_samples(p_lo, p_hi, nu_lo, nu_hi)
    p_corner = p_lo[:, None] + corners[None] * (p_hi - p_lo)[:, None]  # (C, 8, 3)
    n_corner = _unit(-(nu_lo[:, None] + corners[None] * (nu_hi - nu_lo)[:, None]))
    points = np.concatenate([p_mid, p_corner, np.repeat(p_mid, 8, axis=1)], axis=1)
    normals = np.concatenate([n_mid, np.repeat(n_mid, 8, axis=1), n_corner], axis=1)
    return points, normals


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _separating_direction(points, inward, centre, rho: float, quality: QualityOptions) -> np.ndarray | None:
    """``w`` (6,), ``|w|_inf <= 1``, maximising the smallest ``-w . wrench`` over the sample
    contacts' circumscribed cones (``points, inward (C, S, 3)``); ``None`` when that is not
    positive."""
    p, n = points.reshape(-1, 3), inward.reshape(-1, 3)
    frame = orthonormal_frame(n)  # (K, 3, 3) columns t1, t2, n
    theta = 2.0 * np.pi * np.arange(_SAMPLE_EDGES) / _SAMPLE_EDGES
    spread = quality.friction / np.cos(np.pi / _SAMPLE_EDGES)  # circumscribed: holds the whole cone
    forces = n[:, None] + spread * (np.cos(theta)[None, :, None] * frame[:, None, :, 0]
                                    + np.sin(theta)[None, :, None] * frame[:, None, :, 1])  # fmt: skip
    arm = (p - centre)[:, None]
    rows = [np.concatenate([forces, np.cross(arm, forces) / rho], axis=2).reshape(-1, 6)]
    if quality.torsion_mm > 0:
        base = np.cross(p - centre, n)
        for sign in (1.0, -1.0):
            rows.append(np.concatenate([n, (base + sign * quality.torsion_mm * n) / rho], axis=1))
    W = np.vstack(rows)
    A = np.hstack([W, np.ones((len(W), 1))])  # w . wrench + s <= 0
    res = linprog(np.r_[np.zeros(6), -1.0], A_ub=A, b_ub=np.zeros(len(W)),
                  bounds=[(-1.0, 1.0)] * 6 + [(None, 1.0)], method="highs")  # fmt: skip
    if res.status != 0 or -res.fun <= CERTIFICATE_MARGIN:
        return None
    w = res.x[:6]
    return w / np.max(np.abs(w))
