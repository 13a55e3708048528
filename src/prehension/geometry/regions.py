"""Contact regions: Bézier patches, sphere caps and points with normals.

A region lives in the frame of the body that carries it (a hand link or the object) and
is a map from ``k`` parameters to a point and its **outward** unit normal (pointing out
of the body).  Two regions are in contact (eqs. 15-16 of Rosales et al. 2011) when, for
some parameters, their points coincide and their normals are opposed.

* :class:`BezierRegion` (eq. 3): ``k = 2`` parameters ``(u, v)`` in ``[0, 1]^2``;
  the outward normal is ``p_u x p_v / |p_u x p_v|`` (eq. 2).  A patch whose normal
  vanishes somewhere is refused (:class:`~prehension.errors.DegeneratePatch`).
* :class:`SphereCap`: the part of a sphere (centre ``c``, radius ``rho`` [mm]) whose
  outward normal makes an angle of at most ``half_angle`` with the cap axis ``m`` (the
  fingertip model of the SA hand: the ``SPHERICAL`` contact of the CuikSuite files).
  ``k = 2`` parameters ``(alpha, gamma)`` [rad], two rotations of ``m`` about the
  orthogonal axes ``e1``, ``e2`` of the cap frame, as the two "virtual joints" of
  Claret & Suárez (fig. 2b):

  .. math::

      n(\\alpha, \\gamma) = \\mathrm{Rot}(e_1, \\alpha)\\,\\mathrm{Rot}(e_2, \\gamma)\\, m
        = \\cos\\gamma\\cos\\alpha\\, m - \\cos\\gamma\\sin\\alpha\\, e_2 + \\sin\\gamma\\, e_1,
      \\qquad p = c + \\rho\\, n.

  The cone condition ``n . m >= cos(half_angle)`` is not a box on ``(alpha, gamma)``: it
  is reported by :meth:`Region.domain_violation`.
* :class:`PointRegion`: a single point with a normal, ``k = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Sequence

import numpy as np

from ..errors import InvalidGeometry
from .bezier import BezierPatch
from .rotations import angle_between, orthonormal_frame
from .vectors import cross3, unit3, vec3

__all__ = ["Region", "BezierRegion", "SphereCap", "PointRegion", "evaluate_regions"]


def _params(params, k: int) -> np.ndarray:
    arr = np.asarray(params, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != k:
        raise InvalidGeometry(f"region parameters must have shape (B, {k}), got {np.shape(params)}")
    return arr


class Region:
    """Interface of every contact region (all arrays batch-first, mm and rad)."""

    kind: str = "region"
    n_params: int = 0
    #: The region's own frame about its ``center`` [mm]: columns ``(e1, e2, m)``, ``m``
    #: its axis; ``None`` for a kind without one (a sphere cap has one).  Files that hold
    #: frames but no regions (URDF/MJCF hands, :mod:`prehension.hands.export`) mark a
    #: region by it.
    frame: np.ndarray | None = None

    def param_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Box ``(lower (k,), upper (k,))`` that contains the parameter domain."""
        raise NotImplementedError

    def evaluate(self, params) -> tuple[np.ndarray, np.ndarray]:
        """``params (B, k) -> (points (B, 3) [mm], outward unit normals (B, 3))``."""
        raise NotImplementedError

    def jacobian(self, params) -> tuple[np.ndarray, np.ndarray]:
        """``params (B, k) -> (d point / d params (B, 3, k), d normal / d params (B, 3, k))``."""
        raise NotImplementedError

    def domain_violation(self, params) -> np.ndarray:
        """How far ``params (B, k)`` lie outside the region, shape (B,), 0 inside.

        Units: parameter units for patches, degrees for sphere caps.
        """
        raise NotImplementedError

    def evaluate_checked(self, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(points, normals, domain violation)`` of :meth:`evaluate` and
        :meth:`domain_violation` in one call (a region may share work between them)."""
        points, normals = self.evaluate(params)
        return points, normals, self.domain_violation(params)

    def seed_params(self, n: int = 3) -> np.ndarray:
        """A small grid of parameters inside the domain, shape (S, k), for local searches."""
        raise NotImplementedError

    def sample_params(self, n: int = 7) -> np.ndarray:
        """Parameters ``(S, k)`` spread over the whole region (about ``n`` per parameter),
        every one inside the domain: the samples that check a region against its object's
        surface.  By default the :meth:`seed_params` grid inside the domain."""
        params = self.seed_params(n)
        return params[self.domain_violation(params) <= 0]

    def ball(self) -> tuple[np.ndarray, float] | None:
        """The sphere the region lies on, ``(centre (3,) [mm], radius [mm])``, or ``None``
        when it lies on none.  On a hand link this ball is the region's pad: the solid
        that touches the object (a fingertip)."""
        return None

    def cone_margin(self, params) -> tuple[float, np.ndarray] | None:
        """How far inside the cone of allowed normals the parameters ``params (k,)`` lie,
        as a smooth function (>= 0 inside), and its gradient ``(k,)``; ``None`` when the
        region's domain is its parameter box (no cone)."""
        return None

    def transformed(self, R: np.ndarray, t: np.ndarray) -> "Region":
        """The region moved rigidly, ``x -> R x + t`` (its normals turn with it)."""
        raise NotImplementedError

    def centroid(self) -> np.ndarray:
        """The mean of the points that define the region (3,) [mm]: a centre to turn it about."""
        raise NotImplementedError

    def restricted(self, lower: np.ndarray, upper: np.ndarray) -> "Region | None":
        """The part of the region over the parameter box ``[lower, upper]`` (inside
        :meth:`param_bounds`), as a region of its own whose parameter box maps affinely onto
        ``[lower, upper]`` (its parameter ``s`` is this region's ``lower + (upper - lower) *
        (s - l) / (u - l)``, ``(l, u)`` its :meth:`param_bounds`); ``None`` for a kind whose
        part is not a region of its kind (sphere caps, points)."""
        return None

    #: What to tell a user whose region's normal points into its object (its kind's usual cause).
    inward_hint: str = ""

    def describe(self) -> str:
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class BezierRegion(Region):
    """A Bézier patch region; its outward normal is ``p_u x p_v`` normalised."""

    patch: BezierPatch
    kind = "bezier"
    n_params = 2

    def __post_init__(self):
        if not isinstance(self.patch, BezierPatch):
            object.__setattr__(self, "patch", BezierPatch(np.asarray(self.patch, dtype=float)))
        if self.patch.dim != 3:
            raise InvalidGeometry(f"a contact patch needs 3-D control points, got dimension {self.patch.dim}")
        self.patch.check_nondegenerate()

    def param_bounds(self):
        return np.zeros(2), np.ones(2)

    def evaluate(self, params):
        uv = _params(params, 2)
        d = self.patch.derivatives(uv[:, 0], uv[:, 1], order=1)
        normal = cross3(d.p_u, d.p_v)
        return d.p, normal / np.linalg.norm(normal, axis=1, keepdims=True)

    def jacobian(self, params):
        uv = _params(params, 2)
        d = self.patch.derivatives(uv[:, 0], uv[:, 1], order=2)
        N = np.cross(d.p_u, d.p_v)  # (B, 3)
        dN_du = np.cross(d.p_uu, d.p_v) + np.cross(d.p_u, d.p_uv)
        dN_dv = np.cross(d.p_uv, d.p_v) + np.cross(d.p_u, d.p_vv)
        norm = np.linalg.norm(N, axis=1, keepdims=True)
        n = N / norm
        proj = lambda dN: (dN - n * np.sum(n * dN, axis=1, keepdims=True)) / norm  # noqa: E731
        dpoint = np.stack([d.p_u, d.p_v], axis=2)  # (B, 3, 2)
        dnormal = np.stack([proj(dN_du), proj(dN_dv)], axis=2)  # (B, 3, 2)
        return dpoint, dnormal

    def domain_violation(self, params):
        uv = _params(params, 2)
        return np.max(np.maximum(np.maximum(-uv, uv - 1.0), 0.0), axis=1)

    def seed_params(self, n: int = 3):
        t = (np.arange(n) + 0.5) / n
        uu, vv = np.meshgrid(t, t, indexing="ij")
        return np.stack([uu.ravel(), vv.ravel()], axis=1)

    def sample_params(self, n: int = 7):
        """The ``n x n`` grid of the unit square, its edges included."""
        t = np.linspace(0.0, 1.0, n)
        return np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)

    def transformed(self, R, t):
        return BezierRegion(self.patch.transformed(R, t))

    def restricted(self, lower, upper):
        """The sub-patch over ``[lower, upper]`` (de Casteljau subdivision: exact), on ``[0, 1]^2``."""
        (u0, v0), (u1, v1) = np.clip(lower, 0.0, 1.0), np.clip(upper, 0.0, 1.0)
        if not (u1 > u0 and v1 > v0):
            raise InvalidGeometry(f"a restricted patch needs lower < upper inside [0, 1]^2, got {lower} and {upper}")
        return BezierRegion(self.patch.subdivide(float(u0), float(u1), float(v0), float(v1)))

    def centroid(self):
        return self.patch.control_points.reshape(-1, 3).mean(axis=0)

    inward_hint = " (a patch's outward normal is p_u x p_v: list its control points in the other order along one direction)"

    def describe(self) -> str:
        M, N = self.patch.degree
        return f"Bézier patch {M}x{N}"


@dataclass(frozen=True, eq=False)
class SphereCap(Region):
    """Points of a sphere whose outward normal is within ``half_angle`` [rad] of ``axis``."""

    center: np.ndarray
    radius: float
    axis: np.ndarray
    half_angle: float
    kind = "sphere_cap"
    n_params = 2

    def __post_init__(self):
        object.__setattr__(self, "center", vec3(self.center, "sphere cap centre"))
        object.__setattr__(self, "axis", unit3(self.axis, "sphere cap axis"))
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise InvalidGeometry(f"sphere cap radius must be a positive number of mm, got {self.radius}")
        if not (np.isfinite(self.half_angle) and 0 <= self.half_angle <= np.pi + 1e-12):
            raise InvalidGeometry(
                f"sphere cap half-angle must lie in [0, 180] degrees, got {np.degrees(self.half_angle):.6g}"
            )
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "half_angle", float(self.half_angle))

    @classmethod
    def from_degrees(cls, center, radius: float, axis, half_angle_deg: float) -> "SphereCap":
        """The cap with its half-angle in degrees, as task files write it (``half_angle_deg``)."""
        return cls(center, radius, axis, np.radians(float(half_angle_deg)))

    @cached_property
    def frame(self) -> np.ndarray:
        """Columns ``(e1, e2, m)``: an orthonormal frame whose third axis is the cap axis
        (computed once; read-only)."""
        frame = orthonormal_frame(self.axis)
        frame.setflags(write=False)
        return frame

    def param_bounds(self):
        # Beyond 90 deg the cone holds normals with alpha = pi (n = -cos(g) m + sin(g) e1
        # with |g| >= pi - half_angle), so alpha needs its full range.
        a = self.half_angle if self.half_angle <= np.pi / 2 else np.pi
        g = min(self.half_angle, np.pi / 2)
        return np.array([-a, -g]), np.array([a, g])

    def normals(self, params) -> np.ndarray:
        ag = _params(params, 2)
        ca, sa = np.cos(ag[:, 0:1]), np.sin(ag[:, 0:1])
        cg, sg = np.cos(ag[:, 1:2]), np.sin(ag[:, 1:2])
        e1, e2, m = self.frame.T
        return cg * ca * m - cg * sa * e2 + sg * e1

    def evaluate(self, params):
        n = self.normals(params)
        return self.center + self.radius * n, n

    def jacobian(self, params):
        ag = _params(params, 2)
        ca, sa = np.cos(ag[:, 0:1]), np.sin(ag[:, 0:1])
        cg, sg = np.cos(ag[:, 1:2]), np.sin(ag[:, 1:2])
        e1, e2, m = self.frame.T
        dn_da = -cg * sa * m - cg * ca * e2
        dn_dg = -sg * ca * m + sg * sa * e2 + cg * e1
        dnormal = np.stack([dn_da, dn_dg], axis=2)
        return self.radius * dnormal, dnormal

    def domain_violation(self, params):
        return self._cone_violation(self.normals(params))

    def evaluate_checked(self, params):
        n = self.normals(params)  # once for the point, the normal and the cone
        return self.center + self.radius * n, n, self._cone_violation(n)

    def _cone_violation(self, n: np.ndarray) -> np.ndarray:
        """How far normals ``n (B, 3)`` lie outside the cone [deg], 0 inside."""
        angle = np.degrees(angle_between(n, self.axis))
        return np.maximum(angle - np.degrees(self.half_angle), 0.0)

    def params_for_normal(self, normal) -> np.ndarray:
        """Parameters ``(B, 2)`` whose normal is ``normal (B, 3)`` (normalised first)."""
        n = np.atleast_2d(np.asarray(normal, dtype=float))
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        e1, e2, m = self.frame.T
        gamma = np.arcsin(np.clip(n @ e1, -1.0, 1.0))
        alpha = np.arctan2(-(n @ e2), n @ m)
        return np.stack([alpha, gamma], axis=1)

    def ball(self):
        return self.center, self.radius

    def cone_margin(self, params):
        """``n . m - cos(half_angle) = cos(gamma) cos(alpha) - cos(half_angle)`` and its gradient."""
        a, g = params[0], params[1]
        value = np.cos(g) * np.cos(a) - float(np.cos(self.half_angle))
        return value, np.array([-np.cos(g) * np.sin(a), -np.sin(g) * np.cos(a)])

    def transformed(self, R, t):
        R = np.asarray(R, dtype=float)
        return SphereCap(R @ self.center + t, self.radius, R @ self.axis, self.half_angle)

    def centroid(self):
        return self.center.copy()

    def seed_params(self, n: int = 3):
        lo, hi = self.param_bounds()
        t = (np.arange(n) + 0.5) / n
        a = lo[0] + t * (hi[0] - lo[0]) * 0.8 + 0.1 * (hi[0] - lo[0])
        g = lo[1] + t * (hi[1] - lo[1]) * 0.8 + 0.1 * (hi[1] - lo[1])
        aa, gg = np.meshgrid(a, g, indexing="ij")
        return np.stack([aa.ravel(), gg.ravel()], axis=1)

    def describe(self) -> str:
        return f"sphere cap r={self.radius:g} mm, half-angle {np.degrees(self.half_angle):.4g} deg"


@dataclass(frozen=True, eq=False)
class PointRegion(Region):
    """A single contact point with its outward normal (link or object frame)."""

    point: np.ndarray
    normal: np.ndarray
    kind = "point"
    n_params = 0

    def __post_init__(self):
        object.__setattr__(self, "point", vec3(self.point, "contact point"))
        object.__setattr__(self, "normal", unit3(self.normal, "contact normal"))

    def param_bounds(self):
        return np.zeros(0), np.zeros(0)

    def evaluate(self, params):
        B = _params(params, 0).shape[0]
        return np.broadcast_to(self.point, (B, 3)).copy(), np.broadcast_to(self.normal, (B, 3)).copy()

    def jacobian(self, params):
        B = _params(params, 0).shape[0]
        return np.zeros((B, 3, 0)), np.zeros((B, 3, 0))

    def domain_violation(self, params):
        return np.zeros(_params(params, 0).shape[0])

    def seed_params(self, n: int = 3):
        return np.zeros((1, 0))

    def transformed(self, R, t):
        R = np.asarray(R, dtype=float)
        return PointRegion(R @ self.point + t, R @ self.normal)

    def centroid(self):
        return self.point.copy()

    def describe(self) -> str:
        return "point with normal"


# -- many regions at once ------------------------------------------------------------------
def evaluate_regions(regions: Sequence[Region], params: Sequence) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`Region.evaluate_checked` of ``C`` regions, each at its own parameters.

    Args:
        regions: ``C`` regions (any kinds, each in its own frame).
        params: per region, ``(B, k)`` parameters (the same ``B`` for all).

    Returns:
        ``points (B, C, 3)`` [mm], ``normals (B, C, 3)`` and ``violation (B, C)``: column
        ``c`` is what ``regions[c].evaluate_checked(params[c])`` gives.  The sphere caps
        and the points are computed together (the same formulas, element by element, on
        stacked arrays: one configuration of a four-fingertip task costs a few numpy
        calls, not a few per contact); other kinds one by one.
    """
    regions = tuple(regions)
    C = len(regions)
    B = _params(params[0], regions[0].n_params).shape[0] if C else 0
    points, normals, violation = np.empty((B, C, 3)), np.empty((B, C, 3)), np.empty((B, C))
    stacked = _stacked(regions)
    if stacked.caps.size:
        _caps_checked(stacked, [params[c] for c in stacked.caps], points, normals, violation)
    if stacked.points.size:
        points[:, stacked.points] = stacked.point_xyz
        normals[:, stacked.points] = stacked.point_normal
        violation[:, stacked.points] = 0.0
    for c in stacked.others:
        points[:, c], normals[:, c], violation[:, c] = regions[c].evaluate_checked(params[c])
    return points, normals, violation


class _Stacked:
    """The caps and points of a tuple of regions as stacked arrays (see :func:`_stacked`)."""

    def __init__(self, regions: tuple):
        kinds = [type(r) for r in regions]
        self.caps = np.array([c for c, k in enumerate(kinds) if k is SphereCap], dtype=np.intp)
        self.points = np.array([c for c, k in enumerate(kinds) if k is PointRegion], dtype=np.intp)
        self.others = tuple(c for c, k in enumerate(kinds) if k is not SphereCap and k is not PointRegion)
        caps = [regions[c] for c in self.caps]
        self.center = np.array([r.center for r in caps]).reshape(-1, 3)  # (Cc, 3)
        self.radius = np.array([r.radius for r in caps]).reshape(-1, 1)  # (Cc, 1)
        frames = np.array([r.frame.T for r in caps]).reshape(-1, 3, 3)  # rows e1, e2, m
        self.e1, self.e2, self.m = frames[:, 0], frames[:, 1], frames[:, 2]  # (Cc, 3) each
        self.axis = np.array([r.axis for r in caps]).reshape(-1, 3)  # (Cc, 3): the cone's axis as given
        self.half_deg = np.array([np.degrees(r.half_angle) for r in caps])  # (Cc,)
        self.point_xyz = np.array([regions[c].point for c in self.points]).reshape(-1, 3)
        self.point_normal = np.array([regions[c].normal for c in self.points]).reshape(-1, 3)


@lru_cache(maxsize=256)
def _stacked(regions: tuple) -> _Stacked:
    """Stacked arrays of ``regions`` (regions compare by identity: one entry per task shape)."""
    return _Stacked(regions)


def _caps_checked(st: _Stacked, params: list, points, normals, violation) -> None:
    """:meth:`SphereCap.evaluate_checked` of the stacked caps, written into columns ``st.caps``."""
    ag = np.concatenate([_params(p, 2) for p in params], axis=1)  # (B, 2 Cc): (B, Cc, 2) flat
    cos, sin = np.cos(ag).reshape(ag.shape[0], -1, 2), np.sin(ag).reshape(ag.shape[0], -1, 2)
    ca, sa, cg, sg = cos[..., 0:1], sin[..., 0:1], cos[..., 1:2], sin[..., 1:2]
    n = cg * ca * st.m - cg * sa * st.e2 + sg * st.e1  # (B, Cc, 3), as SphereCap.normals
    points[:, st.caps] = st.center + st.radius * n
    normals[:, st.caps] = n
    angle = np.degrees(angle_between(n, st.axis))  # as SphereCap._cone_violation
    violation[:, st.caps] = np.maximum(angle - st.half_deg, 0.0)
