"""Compiled largest self-penetration of a hand (numba): one configuration at a time, no large arrays.

Used by :func:`prehension.hands.collision.max_penetration`; the closest points of two
capsules' segments are :func:`prehension.kernels.segments.closest_points`, which the local
solver's kernel reads too.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels.aot import aot
from ..kernels.jit import njit
from ..kernels.segments import closest_points

__all__ = ["max_depths"]


@njit(cache=True)
def _place(R, r, link, a, b, ends):
    """Segment ends of every capsule in the palm frame: ``ends (S, 2, 3)``."""
    for s in range(link.shape[0]):
        li = link[s]
        for i in range(3):
            ends[s, 0, i] = r[li, i] + R[li, i, 0] * a[s, 0] + R[li, i, 1] * a[s, 1] + R[li, i, 2] * a[s, 2]
            ends[s, 1, i] = r[li, i] + R[li, i, 0] * b[s, 0] + R[li, i, 1] * b[s, 1] + R[li, i, 2] * b[s, 2]


def max_depths(R, r, pairs, stop_at_first: bool) -> np.ndarray:
    """Largest penetration depth per configuration, (B,) [mm].

    Args:
        R, r: link poses (B, L, 3, 3) and (B, L, 3) [mm].
        pairs: the hand's :class:`~prehension.hands.collision.CollisionPairs`.
        stop_at_first: stop at the first penetrating pair of a configuration (its depth
            is then only a lower bound of the largest; enough to tell "collides").
    """
    return aot(_max_depths)(R, r, pairs.link, pairs.a, pairs.b, pairs.radius, pairs.first, pairs.second,
                       pairs.group_start, pairs.link_centre, pairs.link_radius, stop_at_first)  # fmt: skip


@njit(cache=True)
def _spheres_apart(R, r, la, lb, centre, rad):
    """Whether the bounding spheres of links ``la`` and ``lb`` are apart."""
    d = 0.0
    for i in range(3):
        ca = r[la, i] + R[la, i, 0] * centre[la, 0] + R[la, i, 1] * centre[la, 1] + R[la, i, 2] * centre[la, 2]
        cb = r[lb, i] + R[lb, i, 0] * centre[lb, 0] + R[lb, i, 1] * centre[lb, 1] + R[lb, i, 2] * centre[lb, 2]
        d += (ca - cb) ** 2
    return math.sqrt(d) >= rad[la] + rad[lb]


@njit(cache=True)
def _capsule_spheres(ends, radius, half):
    """Radius of each capsule's bounding sphere (centred at its mid-point) [mm]."""
    for s in range(ends.shape[0]):
        d = 0.0
        for i in range(3):
            d += (ends[s, 1, i] - ends[s, 0, i]) ** 2
        half[s] = 0.5 * math.sqrt(d) + radius[s]


@njit(cache=True)
def _group_depth(ends, half, radius, first, second, p0, p1, stop_at_first, pa, pb):
    """Largest penetration depth among pairs ``p0:p1`` [mm] (0 if none)."""
    out = 0.0
    for p in range(p0, p1):
        i = first[p]
        j = second[p]
        d = 0.0
        for m in range(3):
            d += (0.5 * (ends[i, 0, m] + ends[i, 1, m] - ends[j, 0, m] - ends[j, 1, m])) ** 2
        if math.sqrt(d) >= half[i] + half[j]:
            continue  # bounding spheres apart: no penetration
        depth = radius[i] + radius[j] - closest_points(ends[i, 0], ends[i, 1], ends[j, 0], ends[j, 1], pa, pb)
        if depth > out:
            out = depth
            if stop_at_first:
                break
    return out


@njit(cache=True)
def _max_depths(R, r, link, a, b, radius, first, second, group_start, centre, rad, stop_at_first):
    B = R.shape[0]
    out = np.zeros(B)
    ends = np.empty((link.shape[0], 2, 3))
    half = np.empty(link.shape[0])
    pa = np.empty(3)
    pb = np.empty(3)
    for k in range(B):
        _place(R[k], r[k], link, a, b, ends)
        _capsule_spheres(ends, radius, half)
        for g in range(group_start.shape[0] - 1):
            p0 = group_start[g]
            if _spheres_apart(R[k], r[k], link[first[p0]], link[second[p0]], centre, rad):
                continue
            depth = _group_depth(ends, half, radius, first, second, p0, group_start[g + 1], stop_at_first, pa, pb)
            if depth > out[k]:
                out[k] = depth
                if stop_at_first:
                    break
    return out
