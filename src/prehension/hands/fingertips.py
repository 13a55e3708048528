"""Fingertip regions found from a hand's geometry: a sphere cap fitted to each finger's pad.

For a finger whose distal link ``D`` carries surface points (its collision shapes, else
its visual ones; a mesh gives its vertices), in ``D``'s frame [mm]:

1. **Pad frame** (:func:`pad_frame`).  ``o`` is the centre of ``D``'s joint and ``w``
   the joint's (last) axis.  The finger axis ``a`` points from ``o`` towards the tip: to
   the tip frame of the file when there is one (a URDF link merged into ``D``, such as
   ``fftip``), else to the centroid of the points, else along the previous phalanx; it
   is made orthogonal to ``w``.  The joint flexes towards ``s (w x a)`` where ``s`` is
   the sign of the middle of its range (flexion ranges lean to the flexing side: SA
   ``[4, 75]`` deg, Allegro ``[-0.2, 1.6]`` rad); that is the **pad direction** ``d``.
   ``L`` is the points' farthest reach along ``a``.
2. **Pad points.**  With ``r0`` the finger's half-thickness near the tip (90th percentile
   of the distances to the axis line beyond ``L/2``), the provisional cap axis is
   ``m = cos(20 deg) d + sin(20 deg) a`` (the pad, tilted towards the tip, as the SA's
   ``(0.14, 0, 0.99)``), its provisional centre ``c0 = o + (L - r0) a``.  The points within
   70 deg of ``m`` seen from the centre, and not farther back than ``2 r0`` from the tip,
   are the pad.
3. **Sphere.**  Least squares ``|p|^2 = 2 c . p + k`` over the pad points (``r^2 = k +
   |c|^2``); three times: points re-selected around the new centre, those farther from
   the sphere than three times the median distance left out (a box or a phalanx mesh
   beside the tip's), and fitted again.  A fit that leaves ``[0.2, 4] r0`` or moves the
   centre more than ``3 r0`` is replaced by the sphere about ``c0`` whose radius is the
   pad points' mean distance.
4. **Cap.**  Axis ``m``; half-angle the 95th percentile of the pad points' angles from
   ``m``, within ``[20, 60]`` deg.  The report (:class:`~prehension.hands.provenance.TipFit`)
   gives, over every surface point inside the cap's cone (seen from its centre), their
   number and their rms and largest distance from the sphere: how far the real surface
   strays from the cap the solvers use.
5. **Consistent with the link's capsules** (:func:`fit_to_capsules`; the capsules are
   what every collision check judges, and a capsule ball is excused only where it lies
   inside the pad's ball, ``|s - c| <= rho - r``).  A capsule end ball that nearly is the
   pad (``|e - c| + r <= 1.15 rho``: a fingertip mesh enclosed by a capsule a little
   thicker than the sphere fitted to it) is taken into the pad: ``rho`` grows to
   ``|e - c| + r``, so that ball is excused instead of sticking out of the pad at every
   contact.  Then the cap keeps only directions ``u`` where the pad is the outermost
   surface of the link: ``max over capsules of (max(a.u, b.u) - c.u + r) <= rho +`` 0.05 mm
   (a contact there, on a flat surface, sinks no capsule into the object).  The cap axis
   is re-chosen among the pad direction tilted ``0..90`` deg towards the tip, to hold the
   widest cone of such directions (the half-angle still at most step 4's), ties going to
   the tilt nearest :data:`TILT_DEG`; the half-angle is then checked on rings 0.25 deg
   apart and lowered until every direction passes.  Without capsules (no collision
   shapes) step 4 stands.

Any value can be overridden (:class:`TipOverride`, degrees for the angle); a finger with
every value given needs no geometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidHand
from ..geometry.regions import SphereCap
from .model import Hand, HandRegion
from .provenance import TipFit

__all__ = ["PadFrame", "TipOverride", "pad_frame", "cap_axis", "fit_fingertip", "apply_override", "TILT_DEG", "fit_to_capsules"]

TILT_DEG = 20.0  # cap axis: the pad direction tilted this much towards the tip
SELECT_DEG = 70.0  # pad points: within this angle of the cap axis
BACK_RADII = 2.0  # ... and not farther back from the tip than this many half-thicknesses
MIN_HALF_ANGLE_DEG, MAX_HALF_ANGLE_DEG = 20.0, 60.0
_MIN_POINTS = 8
ABSORB_FRACTION = 0.15  # a capsule end ball within rho + this * rho of the pad's centre is taken into the pad
OUTERMOST_MM = 0.05  # a cap direction is kept where no capsule reaches farther than rho + this [mm]
_DIRECTIONS = 4000  # directions sampled on the sphere for step 5


@dataclass(frozen=True)
class PadFrame:
    """Where a finger's pad is, in its distal link's frame (mm, unit vectors).

    Attributes:
        link: the distal link.
        origin: (3,) centre of the link's joint.
        along: (3,) finger axis, from the joint towards the tip.
        hinge: (3,) the joint's flexion axis.
        pad: (3,) the side the joint flexes towards.
        length: reach of the link's geometry (or tip frame) along ``along`` [mm]; 0 if unknown.
        flexion: how the pad side was chosen, in words.
    """

    link: str
    origin: np.ndarray
    along: np.ndarray
    hinge: np.ndarray
    pad: np.ndarray
    length: float
    flexion: str


@dataclass(frozen=True)
class TipOverride:
    """User values for one fingertip cap (None: keep the fitted value).

    Attributes:
        link: the link that carries the cap (default: the finger's distal link).
        center: (3,) sphere centre in that link's frame [mm].
        radius: sphere radius [mm].
        axis: (3,) cap axis in that link's frame.
        half_angle_deg: cap half-angle [deg].
    """

    link: str | None = None
    center: tuple[float, float, float] | None = None
    radius: float | None = None
    axis: tuple[float, float, float] | None = None
    half_angle_deg: float | None = None

    @property
    def given(self) -> tuple[str, ...]:
        return tuple(k for k in ("link", "center", "radius", "axis", "half_angle_deg") if getattr(self, k) is not None)

    @property
    def complete(self) -> bool:
        return all(getattr(self, k) is not None for k in ("center", "radius", "axis", "half_angle_deg"))


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else v * 0.0


def _hinge_and_range(hand: Hand, link: str) -> tuple[np.ndarray, float, float, str]:
    """(flexion axis in the link frame, lower, upper [rad], dof name) of the link's last dof."""
    joint = hand.joint_of_link(link)
    if joint.kind == "universal":
        return joint.axis_in_child, joint.lower[1], joint.upper[1], joint.dof_names[1]
    return joint.R_parent_child_zero.T @ joint.axis_in_parent, joint.lower[0], joint.upper[0], joint.dof_names[0]


def _previous_direction(hand: Hand, link: str) -> np.ndarray:
    """Direction of the previous phalanx (parent joint centre -> this joint), link frame at zero."""
    joint = hand.joint_of_link(link)
    parent_joint = hand.joint_of_link(joint.parent)
    start = parent_joint.origin_in_child if parent_joint is not None else np.zeros(3)
    return joint.R_parent_child_zero.T @ (joint.origin_in_parent - start)


def pad_frame(hand: Hand, link: str, points: np.ndarray | None, tip_hint: np.ndarray | None = None) -> PadFrame | None:
    """The pad frame of distal link ``link`` (see step 1 of the module docstring), or None
    when its axes are degenerate.  ``points (n, 3)`` and ``tip_hint (3,)`` in the link frame [mm]."""
    joint = hand.joint_of_link(link)
    if joint is None:
        return None
    o = joint.origin_in_child
    w, lo, hi, dof = _hinge_and_range(hand, link)
    has_points = points is not None and len(points) > 0
    candidates = [tip_hint - o if tip_hint is not None else None, points.mean(axis=0) - o if has_points else None]
    candidates.append(_previous_direction(hand, link))
    a = np.zeros(3)
    for c in candidates:
        if c is not None:
            c = c - (c @ w) * w
            if np.linalg.norm(c) > 1e-6:
                a = _unit(c)
                break
    if not np.any(a):
        return None
    mid = 0.5 * (lo + hi)
    sign = 1.0 if mid >= 0 else -1.0
    side = "+" if sign > 0 else "-"
    flexion = f"joint angle {dof!r} flexes towards {side} (its range [{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg leans there)"
    if abs(mid) < 0.05 * max(hi - lo, 1e-9):
        flexion = f"joint angle {dof!r} has a symmetric range: assumed to flex towards +"
        sign = 1.0
    d = sign * _unit(np.cross(w, a))
    reach = points - o if has_points else (np.atleast_2d(tip_hint - o) if tip_hint is not None else np.zeros((1, 3)))
    return PadFrame(link, o, a, w, d, float(max(np.max(reach @ a), 0.0)), flexion)


def cap_axis(frame: PadFrame) -> np.ndarray:
    """The cap axis of a pad frame: the pad direction tilted by :data:`TILT_DEG` to the tip."""
    tilt = math.radians(TILT_DEG)
    return _unit(math.cos(tilt) * frame.pad + math.sin(tilt) * frame.along)


# -- the fit ------------------------------------------------------------------------------
def _sphere_lsq(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares sphere through points (n, 3): ``|p|^2 = 2 c . p + k``."""
    A = np.column_stack([2.0 * p, np.ones(len(p))])
    sol = np.linalg.lstsq(A, np.einsum("ij,ij->i", p, p), rcond=None)[0]
    c = sol[:3]
    return c, float(math.sqrt(max(sol[3] + c @ c, 0.0)))


def _angles_deg(p: np.ndarray, c: np.ndarray, m: np.ndarray) -> np.ndarray:
    u = p - c
    cos = (u @ m) / np.maximum(np.linalg.norm(u, axis=1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _select(p, t, frame: PadFrame, c, m, r0) -> np.ndarray:
    return (_angles_deg(p, c, m) <= SELECT_DEG) & (t >= frame.length - BACK_RADII * r0)


def _half_thickness(p: np.ndarray, t: np.ndarray, frame: PadFrame) -> float:
    far = t >= 0.5 * frame.length
    radial = p[far] - frame.origin - np.outer(t[far], frame.along)
    return max(float(np.percentile(np.linalg.norm(radial, axis=1), 90)) if far.any() else 0.0, 1.0)


def _trimmed(p: np.ndarray, sel: np.ndarray, c: np.ndarray, r: float, r0: float) -> np.ndarray:
    """``sel`` without the points much farther from the sphere than the typical one."""
    res = np.abs(np.linalg.norm(p - c, axis=1) - r)
    keep = res <= max(3.0 * float(np.median(res[sel])), 0.05 * r0)
    return sel & keep if (sel & keep).sum() >= _MIN_POINTS else sel


def _fit_sphere(p: np.ndarray, frame: PadFrame, m: np.ndarray):
    """(centre, radius, pad mask) by steps 2-3 of the module docstring."""
    t = (p - frame.origin) @ frame.along
    r0 = _half_thickness(p, t, frame)
    c0 = frame.origin + (frame.length - r0) * frame.along
    c, r, sel = c0, r0, _select(p, t, frame, c0, m, r0)
    for _ in range(3):
        if sel.sum() < _MIN_POINTS:
            break
        c_new, r_new = _sphere_lsq(p[sel])
        if not (0.2 * r0 <= r_new <= 4.0 * r0 and np.linalg.norm(c_new - c0) <= 3.0 * r0):
            c, r = c0, float(np.linalg.norm(p[sel] - c0, axis=1).mean())
            break
        c, r = c_new, r_new
        sel = _trimmed(p, _select(p, t, frame, c, m, r0), c, r, r0)
    return c, r, sel


def _fibonacci(n: int) -> np.ndarray:
    """(n, 3) near-uniform unit directions."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    s = np.sqrt(1.0 - z * z)
    return np.column_stack([s * np.cos(phi), s * np.sin(phi), z])


def _absorbed_radius(c: np.ndarray, rho: float, capsules) -> float:
    """The pad radius grown to enclose every capsule end ball that nearly is the pad (step 5)."""
    out = rho
    for cap in capsules:
        for e in (cap.a, cap.b):
            reach = float(np.linalg.norm(np.asarray(e) - c)) + cap.radius
            if rho < reach <= rho * (1.0 + ABSORB_FRACTION):
                out = max(out, reach)
    return out


def _outermost(c: np.ndarray, rho: float, capsules, u: np.ndarray) -> np.ndarray:
    """(n,) whether the pad ball is the outermost surface of the capsules in each direction ``u (n, 3)``."""
    reach = np.full(len(u), -np.inf)
    for cap in capsules:
        ends = np.maximum(u @ (np.asarray(cap.a) - c), u @ (np.asarray(cap.b) - c))  # (n,)
        reach = np.maximum(reach, ends + cap.radius)
    return reach <= rho + OUTERMOST_MM


def fit_to_capsules(frame: PadFrame, c: np.ndarray, rho: float, half_deg: float, capsules):
    """(rho, cap axis, half-angle [deg]) of step 5: the pad made consistent with the
    distal link's ``capsules`` (link frame), the half-angle at most ``half_deg``."""
    rho = _absorbed_radius(c, rho, capsules)
    u = _fibonacci(_DIRECTIONS)
    blocked = u[~_outermost(c, rho, capsules, u)]
    best = (-1.0, 0.0, cap_axis(frame))
    for tilt in np.arange(0.0, 90.5, 1.0):
        t = math.radians(tilt)
        m = _unit(math.cos(t) * frame.pad + math.sin(t) * frame.along)
        free = float(np.degrees(np.arccos(np.clip(np.max(blocked @ m), -1, 1)))) if len(blocked) else 180.0
        half = min(free, half_deg)
        key = (round(half, 1), -abs(tilt - TILT_DEG))
        if key > best[:2]:
            best = (*key, m)
    return rho, best[2], _shrunk(c, rho, capsules, best[2], max(best[0], 0.0))


def _shrunk(c: np.ndarray, rho: float, capsules, m: np.ndarray, half_deg: float) -> float:
    """``half_deg`` lowered in 0.25 deg steps until the cone about ``m`` holds only
    directions where the pad is outermost, checked on rings 0.25 deg apart, 1 deg around
    (the sampled directions of :func:`fit_to_capsules` are about 3 deg apart)."""
    e1 = _unit(np.cross(m, [1.0, 0, 0] if abs(m[0]) < 0.9 else [0, 1.0, 0]))
    e2 = np.cross(m, e1)
    phi = np.radians(np.arange(0.0, 360.0, 1.0))
    ring = np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), e2)  # (360, 3)
    angles = np.arange(0.0, half_deg + 1e-9, 0.25)
    for k, a in enumerate(angles):
        t = math.radians(a)
        if not _outermost(c, rho, capsules, math.cos(t) * m + math.sin(t) * ring).all():
            return float(angles[k - 1]) if k else 0.0
    return half_deg


def fit_fingertip(finger: str, frame: PadFrame, points: np.ndarray, geometry: str, capsules=()) -> tuple[SphereCap, TipFit]:
    """The sphere cap of a finger's pad and the fit's report (module docstring, steps 2-5).

    Args:
        finger: finger name (for the report).
        frame: the pad frame of its distal link.
        points: (n, 3) surface points of the distal link, link frame [mm].
        geometry: what the points are (``"collision mesh"``...), for the report.
        capsules: the distal link's collision capsules (link frame) for step 5; empty: no step 5.
    """
    m = cap_axis(frame)
    p = np.asarray(points, dtype=float)
    c, r, sel = _fit_sphere(p, frame, m)
    if sel.sum() == 0:
        raise InvalidHand(f"finger {finger!r}: no surface point of link {frame.link!r} lies on its pad side")
    half = float(np.clip(np.percentile(_angles_deg(p[sel], c, m), 95), MIN_HALF_ANGLE_DEG, MAX_HALF_ANGLE_DEG))
    if len(capsules):
        r, m, half = fit_to_capsules(frame, c, r, half, capsules)
    cap = SphereCap(c, r, m, math.radians(half))
    in_cap = _angles_deg(p, c, m) <= half  # the report: every surface point the cap stands for
    in_cap = in_cap if in_cap.any() else sel
    dist = np.abs(np.linalg.norm(p[in_cap] - c, axis=1) - r)
    rms = float(math.sqrt(np.mean(dist**2)))
    return cap, TipFit(finger, frame.link, geometry, int(in_cap.sum()), rms, float(dist.max()), frame.flexion)


def apply_override(cap: SphereCap | None, fit: TipFit | None, finger: str, link: str, override: TipOverride):
    """(the cap with the user's values in place of the fitted ones, its report)."""
    if cap is None and not override.complete:
        missing = [k for k in ("center", "radius", "axis", "half_angle_deg") if getattr(override, k) is None]
        raise InvalidHand(
            f"finger {finger!r}: no fingertip could be fitted (no geometry on link {link!r}); "
            f"give every value of its fingertip (missing: {', '.join(missing)})"
        )
    center = override.center if override.center is not None else cap.center
    radius = override.radius if override.radius is not None else cap.radius
    axis = override.axis if override.axis is not None else cap.axis
    half = math.radians(override.half_angle_deg) if override.half_angle_deg is not None else cap.half_angle
    new = SphereCap(center, radius, axis, half)
    given = override.given
    if override.complete or fit is None:
        report = TipFit(finger, override.link or link, "override", 0, 0.0, 0.0, "", given)
    else:
        report = TipFit(finger, override.link or link, fit.geometry, fit.n_points, fit.rms_mm, fit.max_mm,
                        fit.flexion, given)  # fmt: skip
    return new, report


def tip_region(cap: SphereCap, link: str) -> HandRegion:
    return HandRegion(link, cap)
