"""The closest points of two segments (Ericson, *Real-Time Collision Detection*, sec. 5.1.9).

One code for every caller: capsule pairs (self-collision, the local solver's clearance
rows) and a segment against a mesh's triangle edges (:mod:`prehension.objects.distance`).
Segments ``p0``-``p1`` and ``q0``-``q1`` have the points ``p0 + s (p1 - p0)`` and
``q0 + t (q1 - q0)``, ``s, t`` in ``[0, 1]``; with ``d1 = p1 - p0``, ``d2 = q1 - q0``,
``r = p0 - q0`` and ``a = d1.d1``, ``e = d2.d2``, ``b = d1.d2``, ``c = d1.r``, ``f = d2.r``,

.. math::

    s = \\mathrm{clamp}\\left(\\frac{b f - c e}{a e - b^2}\\right), \\qquad
    t = \\frac{b s + f}{e},

and when ``t`` leaves ``[0, 1]`` it is clamped and ``s`` recomputed for it.

**Degeneracy threshold** ``eps``: a segment with ``|d|^2 <= eps`` is a point, and two
segments with ``a e - b^2 <= eps max(a e, eps)`` are parallel (any ``s`` is a closest one:
``s = 0``).  Callers keep the threshold they were validated with, so that their answers are
unchanged to the bit: :data:`CAPSULE_EPS` (squared lengths in mm^2 of hand capsules) and
:data:`MESH_EPS` (a mesh's edges and the pieces of a capsule's segment, which may be much
shorter).
"""

from __future__ import annotations

import math

import numpy as np

from .jit import njit

__all__ = [
    "CAPSULE_EPS", "MESH_EPS", "clamp01", "segment_params", "segment_params_xyz", "closest_points", "segment_distance_sq",
    "segment_distances",
]  # fmt: skip

CAPSULE_EPS = 1e-12  # [mm^2] a capsule's segment shorter than 1e-6 mm is a point
MESH_EPS = 1e-18  # [mm^2] a mesh edge or a piece of a segment shorter than 1e-9 mm is a point


@njit(cache=True)
def clamp01(x):
    """``x`` clamped into ``[0, 1]``."""
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@njit(cache=True)
def segment_params(p0, p1, q0, q1, eps):
    """``(squared distance, s, t)`` of the closest points ``p0 + s (p1 - p0)`` and
    ``q0 + t (q1 - q0)`` of two segments (3,) [mm]; ``eps`` the degeneracy threshold
    [mm^2] (see the module docstring)."""
    return segment_params_xyz(p0[0], p0[1], p0[2], p1[0], p1[1], p1[2], q0[0], q0[1], q0[2], q1[0], q1[1], q1[2], eps)


@njit(cache=True)
def segment_params_xyz(p0x, p0y, p0z, p1x, p1y, p1z, q0x, q0y, q0z, q1x, q1y, q1z, eps):
    """:func:`segment_params` of the ends' coordinates: scalar code, no array (a caller
    that reads the ends out of larger arrays makes no views of them)."""
    d1x, d1y, d1z = p1x - p0x, p1y - p0y, p1z - p0z
    d2x, d2y, d2z = q1x - q0x, q1y - q0y, q1z - q0z
    rx, ry, rz = p0x - q0x, p0y - q0y, p0z - q0z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    if a <= eps and e <= eps:
        s, t = 0.0, 0.0
    elif a <= eps:
        s, t = 0.0, clamp01(f / e)
    elif e <= eps:
        s, t = clamp01(-c / a), 0.0
    else:
        denom = a * e - b * b
        s = clamp01((b * f - c * e) / denom) if denom > eps * max(a * e, eps) else 0.0
        t = (b * s + f) / e
        if t < 0.0:
            s, t = clamp01(-c / a), 0.0
        elif t > 1.0:
            s, t = clamp01((b - c) / a), 1.0
    wx = rx + d1x * s - d2x * t
    wy = ry + d1y * s - d2y * t
    wz = rz + d1z * s - d2z * t
    return wx * wx + wy * wy + wz * wz, s, t


@njit(cache=True)
def closest_points(p0, p1, q0, q1, pa, pb):
    """Closest points ``pa``, ``pb`` (3,) of two capsules' segments p0-p1 and q0-q1; their
    distance [mm] (:data:`CAPSULE_EPS`)."""
    _, s, t = segment_params_xyz(p0[0], p0[1], p0[2], p1[0], p1[1], p1[2], q0[0], q0[1], q0[2], q1[0], q1[1], q1[2], CAPSULE_EPS)
    d = 0.0
    for i in range(3):
        pa[i] = p0[i] + (p1[i] - p0[i]) * s
        pb[i] = q0[i] + (q1[i] - q0[i]) * t
        d += (pa[i] - pb[i]) ** 2
    return math.sqrt(d)


@njit(cache=True)
def segment_distance_sq(p0, p1, q0, q1, eps):
    """Squared distance of two segments (3,) [mm^2]; ``eps`` as :func:`segment_params`."""
    return segment_params(p0, p1, q0, q1, eps)[0]


@njit(cache=True)
def segment_distances(p0, p1, q0, q1):
    """Distance of segments ``p0[i]``-``p1[i]`` and ``q0[i]``-``q1[i]`` (N, 3) -> (N,) [mm]
    (:data:`CAPSULE_EPS`)."""
    out = np.empty(p0.shape[0])
    for i in range(p0.shape[0]):
        out[i] = math.sqrt(segment_params(p0[i], p1[i], q0[i], q1[i], CAPSULE_EPS)[0])
    return out
