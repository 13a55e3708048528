"""What the complete solver knows about each region kind: its one region adapter.

The complete solver's enclosures (the pair test, the collision and self-collision prunes,
the closure prune) treat regions through the few questions below; each is answered here,
per kind, so that a new region kind touches this module alone in this stage:

* a **hand region fixed on its link** (:func:`hand_tip`): a fingertip sphere cap (a ball
  whose contact normal lies within its half angle of its axis) or a point (radius 0, a
  fixed normal); a hand patch is not one (its point is a product of variables: None);
* the **bounds on an object region's second derivatives** (:func:`region_curvature`, over
  its whole parameter domain, and :func:`local_remainders` per box of a patch's
  parameters) that the pair test's affine forms need for their remainders;
* **boxes holding an object region's points and normals** over a box of the system's
  variables (:func:`object_point_normal_box`, :func:`offset_point_box`), from the region's
  own variables (a point: none; a cap: its normal; a patch: its parameters and normal).

Nothing here imports the rest of the complete solver: its modules import this one.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...geometry.bezier import subdivide_nets
from ...geometry.regions import BezierRegion, PointRegion, SphereCap

__all__ = ["HandTip", "hand_tip", "region_curvature", "local_remainders", "object_point_normal_box", "offset_point_box",
           "NET_SLACK_MM", "SUBDIVIDE_BELOW"]  # fmt: skip

NET_SLACK_MM = 1e-9  # widening of a sub-patch's control-net box (subdivision rounding)
SUBDIVIDE_BELOW = 0.25  # an object patch's (s, t) box smaller than this: bound its sub-patch (~0.5 ms)


# -- hand regions --------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class HandTip:
    """A hand region fixed on its link, in the link's frame.

    Attributes:
        centre: (3,) the cap's centre, or the point [mm].
        radius: the cap's radius; 0 for a point [mm].
        direction: (3,) the cap's axis, or the point's fixed normal (unit, outward from the hand).
        half_angle: the cap's half angle; 0 for a point [rad].
        cone: a cap (the normal lies anywhere within ``half_angle`` of ``direction``) rather
            than a point (the normal is ``direction``).
    """

    centre: np.ndarray
    radius: float
    direction: np.ndarray
    half_angle: float
    cone: bool


def hand_tip(region) -> HandTip | None:
    """The region as a :class:`HandTip`, or None for a hand patch (or any other kind)."""
    if isinstance(region, SphereCap):
        return HandTip(np.asarray(region.center, dtype=float), float(region.radius), region.axis, float(region.half_angle), True)
    if isinstance(region, PointRegion):
        return HandTip(np.asarray(region.point, dtype=float), 0.0, region.normal, 0.0, False)
    return None


# -- object regions: second-derivative bounds (the pair test's remainders) -------------------------
def region_curvature(region) -> tuple[float, float] | None:
    """Bounds on every second partial of a region's point [mm] and unit normal over its
    parameter domain, or None when the region is not supported."""
    if isinstance(region, PointRegion):
        return 0.0, 0.0
    if isinstance(region, SphereCap):
        return float(region.radius), 1.0
    if isinstance(region, BezierRegion):
        return _patch_bounds(region.patch)
    return None


def local_remainders(region, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Per box ``(B, 2)`` of a patch region's parameters, the bounds ``(R_point, R_normal)``
    ``(B,)`` of :func:`patch_remainders`; None for a region that is no patch (its whole
    domain's :func:`region_curvature` is then as tight) or when ``|N|`` may vanish."""
    if not isinstance(region, BezierRegion):
        return None
    return patch_remainders(region.patch, lo, hi)


def _net_max(net: np.ndarray) -> float:
    return float(np.linalg.norm(net.reshape(-1, 3), axis=1).max(initial=0.0))


def _nets_max(nets: np.ndarray) -> np.ndarray:
    """:func:`_net_max` of each of a batch of nets ``(B, ..., 3)`` ``(B,)``."""
    return np.linalg.norm(nets.reshape(len(nets), -1, 3), axis=2).max(axis=1, initial=0.0)


def _hodograph(net: np.ndarray, axis: int) -> np.ndarray:
    """Control net of the derivative of a Bézier patch along ``axis`` (zeros for degree 0)."""
    deg = net.shape[axis] - 1
    if deg == 0:
        return np.zeros_like(net)
    return deg * np.diff(net, axis=axis)


def _patch_bounds(patch) -> tuple[float, float] | None:
    """``(M_point, M_normal)`` bounds on the second partials of a patch's point and unit normal
    over the whole patch, or None when ``|N|`` cannot be bounded away from 0."""
    P = patch.control_points
    second = [_hodograph(_hodograph(P, 0), 0), _hodograph(_hodograph(P, 0), 1), _hodograph(_hodograph(P, 1), 1)]
    Q = patch.normal_patch().control_points
    mean = Q.reshape(-1, 3).mean(axis=0)
    if np.linalg.norm(mean) == 0.0:
        return None
    n_min = float((Q.reshape(-1, 3) @ (mean / np.linalg.norm(mean))).min())  # |N| >= N . u >= this
    if n_min <= 0.0:
        return None
    g1 = max(_net_max(_hodograph(Q, 0)), _net_max(_hodograph(Q, 1)))
    g2 = max(_net_max(_hodograph(_hodograph(Q, i), j)) for i, j in ((0, 0), (0, 1), (1, 1)))
    return max(_net_max(n) for n in second), 2.0 * g2 / n_min + 5.0 * g1 * g1 / n_min**2


@functools.lru_cache(maxsize=64)
def _normal_net(patch) -> np.ndarray:
    """The control net of a patch's normal patch (asked for on every batch of boxes)."""
    return patch.normal_patch().control_points


def patch_remainders(patch, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Per box ``(B, 2)`` of a patch's parameters, bounds ``(R_point, R_normal)`` ``(B,)`` of
    ``1/2 sum_ij |d_ij f| |delta_i| |delta_j|`` over the box for the patch's point and unit
    normal ``f`` (the remainder of a first-order Taylor form at the box's centre), from the
    control nets of the patch and of its normal patch ``N = p_u x p_v`` restricted to the box
    (:func:`~prehension.geometry.bezier.subdivide_nets`; local parameters ``t in [0, 1]^2``,
    ``|delta_i| <= 1/2``).  Second partials of the unit normal ``nu = N / |N|`` (with ``P = I -
    nu nu^T``, ``s = |N|``, ``g1_i >= |d_i N|``, ``g2_ij >= |d_ij N|``)::

        d_ij nu = [P d_ij N - d_j nu (nu . d_i N) - d_i nu (nu . d_j N)] / s - nu (d_j nu . d_i N) / s

    whose parts across and along ``nu`` are at most ``g2_ij / s + 2 g1_i g1_j / s^2`` and
    ``g1_i g1_j / s^2`` (``|d_i nu| <= g1_i / s``).  None when ``|N|`` may vanish on some box
    (``s`` from ``N . e`` with ``e`` the box's mean normal direction).  Bounds of the nets
    (convex hull property), widened by 1e-9 relative for rounding.
    """
    if not len(lo):
        return np.zeros(0), np.zeros(0)
    boxes = np.stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]], axis=1)
    P = subdivide_nets(patch.control_points, boxes)  # (B, m+1, n+1, 3)
    Q = subdivide_nets(_normal_net(patch), boxes)
    # the nets are (B, m+1, n+1, 3): u along axis 1, v along axis 2
    pairs = ((1, 1), (1, 2), (2, 2))
    weight = (1.0, 2.0, 1.0)  # uu, uv + vu, vv
    r_point = sum(w * _nets_max(_hodograph(_hodograph(P, i), j)) for w, (i, j) in zip(weight, pairs)) / 8.0
    mean = Q.reshape(len(Q), -1, 3).mean(axis=1)
    e = mean / np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-300)
    s = np.einsum("bkd,bd->bk", Q.reshape(len(Q), -1, 3), e).min(axis=1)
    if not np.all(s > 0.0):
        return None
    g1 = {1: _nets_max(_hodograph(Q, 1)), 2: _nets_max(_hodograph(Q, 2))}
    r_normal = 0.0
    for w, (i, j) in zip(weight, pairs):
        across = _nets_max(_hodograph(_hodograph(Q, i), j)) / s + 2.0 * g1[i] * g1[j] / s**2
        r_normal = r_normal + w * np.hypot(across, g1[i] * g1[j] / s**2)
    r_normal = r_normal / 8.0
    pad = 1.0 + 1e-9
    return r_point * pad + 1e-300, r_normal * pad + 1e-300


# -- object regions: boxes of points and normals over a box of the system's variables ---------------
def object_point_normal_box(region, variables, lower, upper) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Boxes ``(p_lo, p_hi, nu_lo, nu_hi)`` (3,) holding the object region's point [mm] and unit
    *outward* normal (object frame) for every configuration of the box ``[lower, upper]`` of
    the system's variables; ``variables``: the contact's
    (:attr:`prehension.system.formulation.Formulation.contact_vars`)."""
    if isinstance(region, PointRegion):
        return region.point, region.point, region.normal, region.normal
    idx = np.asarray(variables.object_normal)
    nu_lo, nu_hi = np.maximum(lower[idx], -1.0), np.minimum(upper[idx], 1.0)
    if isinstance(region, SphereCap):
        return region.center + region.radius * nu_lo, region.center + region.radius * nu_hi, nu_lo, nu_hi
    s, t = variables.object_params
    cut = (lower[s], upper[s], lower[t], upper[t])
    net_lo, net_hi = region.patch.subdivide(*cut).bounds()
    n_lo, n_hi = _unit_normal_box(*region.patch.normal_patch().subdivide(*cut).bounds())
    return net_lo - NET_SLACK_MM, net_hi + NET_SLACK_MM, np.maximum(nu_lo, n_lo), np.minimum(nu_hi, n_hi)


def _unit_normal_box(N_lo: np.ndarray, N_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A box holding ``N / |N|`` for every ``N`` of the box ``[N_lo, N_hi]`` (3,) -- the normal
    patch's sub-net box, which holds the sub-patch's ``p_s x p_t`` --, by interval division
    by ``|N|`` in ``[d_min, d_max]``; ``[-1, 1]`` when the box holds the origin."""
    N_lo, N_hi = N_lo - NET_SLACK_MM, N_hi + NET_SLACK_MM
    nearest = np.clip(0.0, N_lo, N_hi)
    d_min = float(np.linalg.norm(nearest))
    if d_min <= 0.0:
        return -np.ones(3), np.ones(3)
    d_max = float(np.linalg.norm(np.maximum(np.abs(N_lo), np.abs(N_hi))))
    lo = np.where(N_lo >= 0, N_lo / d_max, N_lo / d_min)  # the smallest quotient: over the largest |N| when positive
    hi = np.where(N_hi >= 0, N_hi / d_min, N_hi / d_max)
    return np.clip(lo - 1e-12 * np.abs(lo) - 1e-15, -1, 1), np.clip(hi + 1e-12 * np.abs(hi) + 1e-15, -1, 1)  # outward rounding


def offset_point_box(region, variables, lower, upper, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` (3,) [mm] holding ``o + rho nu`` (the centre of a ball of radius ``rho``
    touching the object region at ``o``, normal ``nu``) over the box ``[lower, upper]`` of the
    system's variables, unpadded.  A patch's point is bounded by its whole control net, or,
    when its parameters' box is smaller than :data:`SUBDIVIDE_BELOW`, by its sub-patch's."""
    if isinstance(region, PointRegion):
        lo = hi = np.asarray(region.point, dtype=float) + rho * np.asarray(region.normal, dtype=float)
        return lo, hi
    nu = list(variables.object_normal)
    n_lo, n_hi = np.clip(lower[nu], -1.0, 1.0), np.clip(upper[nu], -1.0, 1.0)
    if isinstance(region, SphereCap):
        reach, (o_lo, o_hi) = region.radius + rho, (np.asarray(region.center, dtype=float),) * 2
    else:
        (s, t), reach = variables.object_params, rho
        u = np.clip([lower[s], upper[s], lower[t], upper[t]], 0.0, 1.0)
        wide = (u[1] - u[0]) * (u[3] - u[2]) > SUBDIVIDE_BELOW  # the whole patch's box will do
        o_lo, o_hi = (region.patch if wide else region.patch.subdivide(*u)).bounds()
    return o_lo + reach * n_lo, o_hi + reach * n_hi
