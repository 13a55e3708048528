"""The formulation stage's region adapter: what each region kind brings to the system.

One class per region kind (:class:`BezierForm`, :class:`CapForm`, :class:`PointForm`),
found by :func:`form_of`; this is the only module of :mod:`prehension.system` that knows
the kinds, so a new region kind touches this one place of the formulation stage.  Each
class knows, for its kind:

* the contact's **equations**: the object side's point ``o`` and unit outward normal
  ``nu`` (:meth:`RegionForm.object_side`), the hand side's equations that put the hand
  region on ``o`` with normal ``-nu`` (:meth:`RegionForm.hand_side`), and the centre of
  the hand ball the reach constraints use (:meth:`RegionForm.reach_point`);
* the **bounds**: a ball fixed to the link that holds a hand region
  (:meth:`RegionForm.ball`) and the points whose box holds an object region
  (:meth:`RegionForm.box_points`);
* the **maps** between configurations and system points: the values of the region's base
  variables (:meth:`RegionForm.normal_value`) and its parameters read back from a point
  (:meth:`RegionForm.object_params`, :meth:`RegionForm.hand_params`).

The builder steps are taken on the formulator of :mod:`.formulation` (passed in as ``f``:
its builder ``f.b`` and its helpers ``unit_vector``, ``in_object``, ``dot_lin``, ``base``),
in the order the system's equations have always come out in.  Nothing here imports
:mod:`.formulation` or :mod:`.embedding`; both import this module.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from .builder import Lin, lin_sum
from .keys import ContactVariables, NormalLength, PatchParameter, Side

__all__ = ["RegionForm", "BezierForm", "CapForm", "PointForm", "form_of"]


class RegionForm:
    """The interface every region kind implements for the formulation (see the module docstring)."""

    #: Whether the system knows the centre of the region's hand ball exactly (no slack).
    exact_centre: bool = False

    def object_side(self, f, ci: int, region) -> tuple[list[Lin], list[Lin], ContactVariables]:
        """Object point, unit outward normal (object frame) and variables of contact ``ci``."""
        raise NotImplementedError

    def hand_side(self, f, ci: int, link: str, region, pos, o, nh, info: ContactVariables) -> ContactVariables:
        """Add the equations that put hand ``region`` (on ``link``, origin ``pos``) on ``o``
        with normal ``nh``; returns ``info`` with the hand variables filled in."""
        raise NotImplementedError

    def reach_point(self, region, o: list[Lin], nu: list[Lin]) -> list[Lin]:
        """The centre of contact's hand ball in the object frame (``o`` unless known better)."""
        return o

    def ball(self, region) -> tuple[np.ndarray, float]:
        """A ball (centre in the link frame [mm], radius [mm]) holding every point of a hand region."""
        raise NotImplementedError

    def box_points(self, region) -> np.ndarray:
        """Points ``(P, 3)`` [mm] whose bounding box holds every point of an object region."""
        raise NotImplementedError

    def normal_value(self, region, params: np.ndarray, key) -> float:
        """The value of the normal variable ``key`` (a :class:`UnitNormal` or :class:`NormalLength`) at ``params``."""
        raise NotImplementedError

    def object_params(self, region, variables: ContactVariables, x: np.ndarray) -> np.ndarray:
        """An object region's parameters read from the system point ``x``."""
        return np.zeros(0)

    def hand_params(self, region, variables: ContactVariables, x: np.ndarray, nu: np.ndarray, R_object_link) -> np.ndarray:
        """A hand region's parameters from ``x``; ``nu``: the object normal (object frame),
        ``R_object_link``: its link's rotation."""
        return np.zeros(0)


class BezierForm(RegionForm):
    """A Bézier patch: Bernstein point and normal patch, ``N = mu nu`` (eqs. 22-25)."""

    def object_side(self, f, ci, region):
        p, nu, st = _patch(f, ci, region.patch, Side.OBJECT)
        return [Lin.var(i) for i in p], [Lin.var(i) for i in nu], ContactVariables(st, tuple(nu))

    def hand_side(self, f, ci, link, region, pos, o, nh, info):
        return replace(info, hand_params=_hand_patch(f, ci, link, region.patch, pos, o, nh))

    def ball(self, region):
        points = region.patch.control_points.reshape(-1, 3)  # the patch lies in their convex hull
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        return centre, float(np.linalg.norm(points - centre, axis=1).max())

    def box_points(self, region):
        return region.patch.control_points.reshape(-1, 3)

    def normal_value(self, region, params, key):
        N = region.patch.normal_patch().evaluate(params[0:1], params[1:2])[0]
        mu = float(np.linalg.norm(N))
        return mu if isinstance(key, NormalLength) else float((N / mu)[key.axis])

    def object_params(self, region, variables, x):
        return np.clip(x[list(variables.object_params)], 0.0, 1.0)

    def hand_params(self, region, variables, x, nu, R_object_link):
        return np.clip(x[list(variables.hand_params)], 0.0, 1.0)


class CapForm(RegionForm):
    """A sphere cap: ``r_k + R_k c - rho nu = o`` and its cone; an object cap's point is ``c + rho nu``."""

    exact_centre = True  # the cap's centre, o - r n_hand, has no slack

    def object_side(self, f, ci, region):
        nu = f.unit_vector(ci, Side.OBJECT, f"onu{ci}")
        f.b.inequality(Lin.constant(np.cos(region.half_angle)) - lin_sum(Lin.var(i, m) for i, m in zip(nu, region.axis)))
        o = [Lin.constant(region.center[r]) + Lin.var(nu[r], region.radius) for r in range(3)]
        return o, [Lin.var(i) for i in nu], ContactVariables(object_normal=tuple(nu))

    def hand_side(self, f, ci, link, region, pos, o, nh, info):
        b = f.b
        cw = f.in_object(link, region.center)
        for r in range(3):
            b.equation(pos[r] + cw[r] + nh[r] * region.radius - o[r])  # (15) on the sphere
        if region.half_angle < np.pi:
            m = f.in_object(link, region.axis)
            b.inequality(Lin.constant(np.cos(region.half_angle)) - f.dot_lin(nh, m, f"m{ci}"))
        return info

    def reach_point(self, region, o, nu):
        return [o[r] + nu[r] * region.radius for r in range(3)]

    def ball(self, region):
        return np.asarray(region.center, dtype=float), float(region.radius)

    def box_points(self, region):
        return np.array([region.center - region.radius, region.center + region.radius])

    def normal_value(self, region, params, key):  # an object cap: its normal, no patch
        return float(region.normals(params[None])[0][key.axis])

    def object_params(self, region, variables, x):
        nu = x[list(variables.object_normal)]
        return np.zeros(2) if np.linalg.norm(nu) < 1e-6 else region.params_for_normal(nu)[0]

    def hand_params(self, region, variables, x, nu, R_object_link):
        if np.linalg.norm(nu) < 1e-6:  # no direction in this point: the cap's axis
            return np.zeros(2)
        return region.params_for_normal(R_object_link.T @ -nu)[0]


class PointForm(RegionForm):
    """A point with a normal: constants on the object side, ``r_k + R_k p = o``, ``R_k n = -nu`` on the hand."""

    def object_side(self, f, ci, region):
        return [Lin.constant(x) for x in region.point], [Lin.constant(x) for x in region.normal], ContactVariables()

    def hand_side(self, f, ci, link, region, pos, o, nh, info):
        pw, nw = f.in_object(link, region.point), f.in_object(link, region.normal)
        for r in range(3):
            f.b.equation(pos[r] + pw[r] - o[r])
            f.b.equation(nw[r] - nh[r])
        return info

    def ball(self, region):
        return np.asarray(region.point, dtype=float), 0.0

    def box_points(self, region):
        return region.point[None]


_BEZIER, _CAP, _POINT = BezierForm(), CapForm(), PointForm()


def form_of(region: Region) -> RegionForm:
    """The formulation of ``region``'s kind; a kind the system cannot express is refused by name."""
    if isinstance(region, BezierRegion):
        return _BEZIER
    if isinstance(region, SphereCap):
        return _CAP
    if isinstance(region, PointRegion):
        return _POINT
    raise TypeError(f"the polynomial system has no equations for a {type(region).__name__} region")


# -- Bézier patches: shared by the object and the hand side -----------------------------------
def _patch(f, ci: int, patch, side: Side):
    """Bernstein point, unit normal and ``(s, t)`` of a Bézier patch (in its own frame)."""
    b, tag = f.b, "o" if side == Side.OBJECT else "h"
    s = f.base(PatchParameter(ci, side, 0), f"{tag}s{ci}", 0.0, 1.0)
    t = f.base(PatchParameter(ci, side, 1), f"{tag}t{ci}", 0.0, 1.0)
    cp, ncp = patch.control_points, patch.normal_patch().control_points
    p = [b.bernstein_var(f"{tag}p{ci}[{r}]", s, t, cp[:, :, r]) for r in range(3)]
    N = [b.bernstein_var(f"{tag}N{ci}[{r}]", s, t, ncp[:, :, r]) for r in range(3)]
    nu = f.unit_vector(ci, side, f"{tag}nu{ci}")
    mu = f.base(NormalLength(ci, side), f"{tag}mu{ci}", 0.0, float(np.linalg.norm(ncp, axis=2).max()))
    for r in range(3):
        b.equation(Lin.var(N[r]) - Lin.var(b.product(mu, nu[r])))  # N = mu nu (22-25)
    return p, nu, (s, t)


def _hand_patch(f, ci, link, patch, pos, o, nh) -> tuple[int, int]:
    """A hand patch's contact equations; returns its ``(s, t)`` variables."""
    b = f.b
    hp, hn, st = _patch(f, ci, patch, Side.HAND)
    R = f.R_object_link[link]
    for r in range(3):
        point = lin_sum(Lin.var(b.product(R[r, c], hp[c])) for c in range(3))  # R_k h
        normal = lin_sum(Lin.var(b.product(R[r, c], hn[c])) for c in range(3))  # R_k m
        b.equation(pos[r] + point - o[r])
        b.equation(normal - nh[r])
    return st
