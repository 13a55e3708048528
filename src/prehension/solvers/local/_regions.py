"""Region kinds for the kernel: each kind's data layout (named offsets) and its compiled code.

The local solver's one place per region kind: a new kind adds its layout, :func:`pack` /
:func:`code` / :func:`reference_point` / :func:`size` / :func:`unknown_box` entries (and,
if its parameters are virtual fingertip joints or it has a cone of normals,
:func:`virtual_joints` / :func:`cone_params`) and its two compiled adapters
(``_<kind>_eval``, ``_<kind>_project``), and the dispatchers :func:`evaluate`,
:func:`project` and :func:`rim_gradient` route to them.  The rest of the local solver
asks these functions and never tests a region's kind itself.

Layouts (one row of a problem's ``data`` per region, starting at its offset ``off``):

* point (``K_POINT``, no parameters): ``PT_POINT`` (3), ``PT_NORMAL`` (3);
* sphere cap (``K_CAP``, parameters ``(alpha, gamma)``, the paper's virtual fingertip
  joints): ``CAP_CENTRE`` (3), ``CAP_RADIUS``, ``CAP_E1`` (3), ``CAP_E2`` (3), ``CAP_AXIS``
  (3), ``CAP_HALF`` (half angle [rad]); the normal is
  ``n = cos g cos a m - cos g sin a e2 + sin g e1`` and the point ``centre + radius n``;
* Bézier patch (``K_BEZIER``, parameters ``(u, v)`` in [0, 1]^2): control point
  ``b_ij`` at ``off + 3 (i (n + 1) + j)``, degree ``(m, n)`` in the contact table.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...errors import InvalidTask
from ...geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from ...kernels.jit import njit

__all__ = [
    "K_POINT", "K_CAP", "K_BEZIER", "MAX_DEGREE", "code", "pack", "reference_point", "size", "unknown_box",
    "evaluate", "project", "rim_gradient", "start_params", "RegionScratch", "virtual_joints", "cone_params",
]  # fmt: skip

K_POINT, K_CAP, K_BEZIER = 0, 1, 2
MAX_DEGREE = 15
WORK_COLS = max(18, MAX_DEGREE + 1)  # columns of the scratch array of :func:`evaluate`

PT_POINT, PT_NORMAL, POINT_SIZE = 0, 3, 6
CAP_CENTRE, CAP_RADIUS, CAP_E1, CAP_E2, CAP_AXIS, CAP_HALF, CAP_SIZE = 0, 3, 4, 7, 10, 13, 14


# -- Python side: what the kernel needs of a region ---------------------------------------------
def code(region: Region) -> tuple[int, int, int, int]:
    """``(kind, m, n, data size)`` of a region."""
    if isinstance(region, PointRegion):
        return K_POINT, 0, 0, POINT_SIZE
    if isinstance(region, SphereCap):
        return K_CAP, 0, 0, CAP_SIZE
    if isinstance(region, BezierRegion):
        m, n = region.patch.degree
        if max(m, n) > MAX_DEGREE:
            raise InvalidTask(f"the local solver handles Bézier patches up to degree {MAX_DEGREE}, got {m}x{n}")
        return K_BEZIER, m, n, 3 * (m + 1) * (n + 1)
    raise InvalidTask(f"the local solver handles points, sphere caps and Bézier patches; got a region of kind {region.kind!r}")


_PACKED: dict[int, tuple[Region, np.ndarray]] = {}


def pack(region: Region) -> np.ndarray:
    """The region's numbers in its kernel layout (see the module docstring); kept for the
    last few thousand region objects (regions are frozen)."""
    hit = _PACKED.get(id(region))
    if hit is not None and hit[0] is region:
        return hit[1]
    data = _pack(region)
    if len(_PACKED) > 4096:
        _PACKED.clear()
    _PACKED[id(region)] = (region, data)
    return data


def _pack(region: Region) -> np.ndarray:
    if isinstance(region, PointRegion):
        return np.concatenate([region.point, region.normal])
    if isinstance(region, SphereCap):
        e1, e2, m = region.frame.T
        return np.concatenate([region.center, [region.radius], e1, e2, m, [region.half_angle]])
    if isinstance(region, BezierRegion):
        return np.asarray(region.patch.control_points, dtype=float).ravel()
    raise InvalidTask(f"unsupported region kind {region.kind!r}")


def reference_point(region: Region) -> np.ndarray:
    """A representative point of a region (its frame) [mm]: pivots and sizes."""
    if isinstance(region, PointRegion):
        return region.point
    if isinstance(region, SphereCap):
        return region.center + region.radius * region.axis
    return region.patch.evaluate(0.5, 0.5)[0]


def size(region: Region) -> float:
    """How far the region's point moves per unit of its parameters [mm]."""
    if isinstance(region, SphereCap):
        return float(region.radius)
    if isinstance(region, BezierRegion):
        lo, hi = region.patch.bounds()
        return float(max(np.linalg.norm(np.asarray(hi) - np.asarray(lo)), 1.0))
    return 1.0


def unknown_box(region: Region) -> tuple[np.ndarray, np.ndarray, bool, np.ndarray]:
    """``(lower, upper, boxed, start)`` of the region's parameters as kernel unknowns.

    ``boxed``: the box is the domain (patches); a cap's cone is kept by :func:`project`
    instead, its box only bounds the start grid.
    """
    if isinstance(region, BezierRegion):
        return np.zeros(2), np.ones(2), True, np.full(2, 0.5)
    if isinstance(region, SphereCap):
        if region.half_angle <= np.pi / 2:
            lo, hi = region.param_bounds()
        else:
            lo, hi = np.array([-np.pi, -np.pi / 2]), np.array([np.pi, np.pi / 2])
        return lo, hi, False, np.zeros(2)
    return np.zeros(0), np.zeros(0), False, np.zeros(0)


def virtual_joints(region: Region) -> bool:
    """Whether a region's parameters are the paper's virtual fingertip joints ``(alpha,
    gamma)``: a sphere cap.  Such a region on a finger's tip link is part of the hand's
    pose space (:func:`.sequence.pose_space`) and a fingertip of the off-line search."""
    return isinstance(region, SphereCap)


def cone_params(region: Region, rng, n: int, rim_fraction: float) -> np.ndarray | None:
    """``n`` parameter vectors of a region whose normals are uniform over its cone of
    normals (a sphere cap's area), a share ``rim_fraction`` of them exactly on its rim
    (the cone's boundary), (n, 2); ``None`` for a kind without such a cone (points, patches)."""
    if not isinstance(region, SphereCap):
        return None
    h = min(region.half_angle, np.pi)
    cos_t = rng.uniform(np.cos(h), 1.0, n)
    cos_t[rng.uniform(0.0, 1.0, n) < rim_fraction] = np.cos(h)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t**2, 0.0))
    e1, e2, m = region.frame.T
    normals = cos_t[:, None] * m + sin_t[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    return region.params_for_normal(normals)


class RegionScratch(NamedTuple):
    """Outputs of :func:`evaluate` when called from Python (the kernel passes its workspace):
    ``pt``, ``nr`` (3,), ``dpt``, ``dnr`` (3, 2), ``work`` (7, WORK_COLS)."""

    pt: np.ndarray
    nr: np.ndarray
    dpt: np.ndarray
    dnr: np.ndarray
    work: np.ndarray

    @classmethod
    def allocate(cls) -> "RegionScratch":
        return cls(np.zeros(3), np.zeros(3), np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((7, WORK_COLS)))


# -- compiled adapters ------------------------------------------------------------------------
@njit(cache=True)
def _point_eval(data, off, ws):
    for i in range(3):
        ws.pt[i] = data[off + PT_POINT + i]
        ws.nr[i] = data[off + PT_NORMAL + i]


@njit(cache=True)
def _cap_eval(data, off, a, g, want_jac, ws):
    pt, nr, dpt, dnr = ws.pt, ws.nr, ws.dpt, ws.dnr
    ca, sa, cg, sg = math.cos(a), math.sin(a), math.cos(g), math.sin(g)
    rho = data[off + CAP_RADIUS]
    for i in range(3):
        e1 = data[off + CAP_E1 + i]
        e2 = data[off + CAP_E2 + i]
        m = data[off + CAP_AXIS + i]
        nr[i] = cg * ca * m - cg * sa * e2 + sg * e1
        pt[i] = data[off + CAP_CENTRE + i] + rho * nr[i]
        if want_jac:
            dnr[i, 0] = -cg * sa * m - cg * ca * e2
            dnr[i, 1] = -sg * ca * m + sg * sa * e2 + cg * e1
            dpt[i, 0] = rho * dnr[i, 0]
            dpt[i, 1] = rho * dnr[i, 1]


@njit(cache=True)
def _bernstein(m, t, out):
    """Bernstein basis of degree ``m`` at ``t`` and its first two derivatives: ``out[0..2, :m+1]``."""
    for r in range(3):
        for i in range(MAX_DEGREE + 1):
            out[r, i] = 0.0
    for d in range(3):  # basis of degree m - d, then differentiated d times
        deg = m - d
        if deg < 0:
            continue
        out[d, 0] = 1.0
        for k in range(1, deg + 1):
            for i in range(k, -1, -1):
                out[d, i] = (1.0 - t) * (out[d, i] if i < k else 0.0) + t * (out[d, i - 1] if i >= 1 else 0.0)
        for _ in range(d):  # derivative: B'_i^p = p (B_{i-1}^{p-1} - B_i^{p-1})
            deg += 1
            for i in range(deg, -1, -1):
                out[d, i] = deg * ((out[d, i - 1] if i >= 1 else 0.0) - (out[d, i] if i < deg else 0.0))


@njit(cache=True)
def _bezier_eval(data, side, u, v, want_jac, ws):
    """Point, unit normal ``p_u x p_v / |.|`` and their derivatives (scratch ``ws.work``)."""
    off, m, n, work = side[1], side[2], side[3], ws.work
    _bernstein(m, u, work[0:3])
    _bernstein(n, v, work[3:6])
    d = work[6]  # p, p_u, p_v, p_uu, p_uv, p_vv: 6 x 3 numbers
    for k in range(18):
        d[k] = 0.0
    for i in range(m + 1):
        for j in range(n + 1):
            w = (work[0, i] * work[3, j], work[1, i] * work[3, j], work[0, i] * work[4, j],
                 work[2, i] * work[3, j], work[1, i] * work[4, j], work[0, i] * work[5, j])  # fmt: skip
            base = off + 3 * (i * (n + 1) + j)
            for r in range(6):
                for k in range(3):
                    d[3 * r + k] += w[r] * data[base + k]
    _bezier_normal(d, ws.pt, ws.nr, ws.dpt, ws.dnr, want_jac)


@njit(inline="always")
def _cross_at(d, a, b, out, o):
    """``out[o:o+3] = d[a:a+3] x d[b:b+3]``; inlined into its caller, as its constant offsets would
    otherwise compile one specialisation per call site."""
    out[o + 0] = d[a + 1] * d[b + 2] - d[a + 2] * d[b + 1]
    out[o + 1] = d[a + 2] * d[b + 0] - d[a + 0] * d[b + 2]
    out[o + 2] = d[a + 0] * d[b + 1] - d[a + 1] * d[b + 0]


@njit(cache=True)
def _bezier_normal(d, pt, nr, dpt, dnr, want_jac):
    """From ``d = (p, p_u, p_v, p_uu, p_uv, p_vv)`` (flat): the point, normal and derivatives."""
    c = np.empty(15)  # N = p_u x p_v, then the four cross products of its derivatives
    _cross_at(d, 3, 6, c, 0)
    norm = max(math.sqrt(c[0] ** 2 + c[1] ** 2 + c[2] ** 2), 1e-300)
    for k in range(3):
        pt[k] = d[k]
        nr[k] = c[k] / norm
    if not want_jac:
        return
    _cross_at(d, 9, 6, c, 3)  # p_uu x p_v
    _cross_at(d, 3, 12, c, 6)  # p_u x p_uv
    _cross_at(d, 12, 6, c, 9)  # p_uv x p_v
    _cross_at(d, 3, 15, c, 12)  # p_u x p_vv
    su = sv = 0.0
    for k in range(3):
        su += nr[k] * (c[3 + k] + c[6 + k])
        sv += nr[k] * (c[9 + k] + c[12 + k])
    for k in range(3):
        dpt[k, 0] = d[3 + k]
        dpt[k, 1] = d[6 + k]
        dnr[k, 0] = (c[3 + k] + c[6 + k] - nr[k] * su) / norm
        dnr[k, 1] = (c[9 + k] + c[12 + k] - nr[k] * sv) / norm


@njit(cache=True)
def evaluate(side, data, x, want_jac, ws):
    """Point ``ws.pt``, outward unit normal ``ws.nr`` (region frame) and their derivatives
    ``ws.dpt``, ``ws.dnr`` (3 x k) of the region described by ``side`` (a row of
    :attr:`._layout.Layout.sides`) at its parameters in ``x``."""
    kind, off, x0 = side[0], side[1], side[4]
    if kind == K_POINT:
        _point_eval(data, off, ws)
    elif kind == K_CAP:
        _cap_eval(data, off, x[x0], x[x0 + 1], want_jac, ws)
    else:
        _bezier_eval(data, side, x[x0], x[x0 + 1], want_jac, ws)


@njit(cache=True)
def start_params(kind, x, x0):
    """A region's parameters at their start value (patch centre, cap axis)."""
    if kind == K_BEZIER:
        x[x0], x[x0 + 1] = 0.5, 0.5
    elif kind == K_CAP:
        x[x0], x[x0 + 1] = 0.0, 0.0


@njit(cache=True)
def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


@njit(cache=True)
def _cap_project(data, off, x, x0, margin):
    """Cap parameters into ``gamma in [-pi/2, pi/2]`` and the cone shrunk by ``margin`` [rad]."""
    a, g = x[x0], x[x0 + 1]
    if a > math.pi or a <= -math.pi:
        a = _wrap(a)
    if g > 0.5 * math.pi or g < -0.5 * math.pi:  # same normal with alpha + pi
        g = (math.pi if g > 0 else -math.pi) - g
        a = _wrap(a + math.pi)
    half = data[off + CAP_HALF]
    lim = max(half - margin, 0.0)
    if half < math.pi and math.cos(g) * math.cos(a) < math.cos(lim):
        n1, n2 = math.sin(g), -math.cos(g) * math.sin(a)  # normal along e1, e2
        s = math.sqrt(n1 * n1 + n2 * n2)
        if s > 1e-300:
            sl = math.sin(lim)
            g = math.asin(min(1.0, max(-1.0, sl * n1 / s)))
            a = math.atan2(-sl * n2 / s, math.cos(lim))
        else:  # opposite to the axis: any direction on the rim
            g, a = min(lim, 0.5 * math.pi), 0.0
    x[x0], x[x0 + 1] = a, g


@njit(cache=True)
def project(kind, off, data, x, x0, lo, hi, margin):
    """Keep one region's parameters in its domain: patches in [0, 1]^2, caps in their cone."""
    if kind == K_BEZIER:
        for k in range(x0, x0 + 2):
            x[k] = min(max(x[k], lo[k]), hi[k])
    elif kind == K_CAP:
        _cap_project(data, off, x, x0, margin)


@njit(cache=True)
def rim_gradient(kind, off, data, x, x0, margin):
    """``(on the rim, g_a, g_g)``: unit gradient of ``n . axis`` in ``(alpha, gamma)`` when a
    cap's parameters lie on its (shrunk) cone's rim; ``(False, 0, 0)`` otherwise."""
    if kind != K_CAP or data[off + CAP_HALF] >= math.pi:
        return False, 0.0, 0.0
    lim = max(data[off + CAP_HALF] - margin, 0.0)
    a, g = x[x0], x[x0 + 1]
    if math.cos(g) * math.cos(a) > math.cos(lim) + 1e-12:
        return False, 0.0, 0.0
    ga, gg = -math.cos(g) * math.sin(a), -math.sin(g) * math.cos(a)
    nrm = math.sqrt(ga * ga + gg * gg)
    if nrm < 1e-12:
        return False, 0.0, 0.0
    return True, ga / nrm, gg / nrm
