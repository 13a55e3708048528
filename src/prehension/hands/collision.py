"""Self-collision of a hand from its capsule collision shapes.

Two links are checked against each other unless a joint joins them directly or the hand
lists the pair in ``collision_exclusions``.  The clearance of two capsules is the distance
between their segments minus the two radii; a negative clearance is a penetration depth.

Memory is bounded for any hand: a hand with hundreds of capsules has tens of thousands of
pairs (the LEAP hand of dex-urdf: 238 capsules, 22,564 pairs), and a batch of thousands
of configurations times that many pairs does not fit in memory at once.
:func:`capsule_clearances` returns every pair's clearance (``B x P`` numbers);
:func:`max_penetration` (compiled, one configuration at a time, capsules whose bounding
spheres are apart skipped) needs no array larger than the list of capsules.  The pair list of a hand is built once and kept in a cache keyed by the
hand object (never written onto the frozen :class:`~prehension.hands.model.Hand`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._compiled import aot
from ..frozen import cached_per_value
from .kinematics import HandPose
from .model import Hand

__all__ = [
    "CollisionPairs",
    "collision_pairs",
    "segment_distance",
    "capsule_clearances",
    "max_penetration",
]

def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Distance between segments p0-p1 and q0-q1, all arrays (..., 3) [mm] -> (...)

    The closest-point parameters are found in closed form (Ericson, *Real-Time Collision
    Detection*, sec. 5.1.9) with every degenerate case (points, parallel segments) handled
    by clamping, vectorised over the leading axes.
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.sum(d1 * d1, axis=-1)
    e = np.sum(d2 * d2, axis=-1)
    f = np.sum(d2 * r, axis=-1)
    c = np.sum(d1 * r, axis=-1)
    b = np.sum(d1 * d2, axis=-1)
    denom = a * e - b * b
    tiny = 1e-12
    safe = lambda x: np.where(x > tiny, x, 1.0)  # noqa: E731
    s = np.where(denom > tiny * np.maximum(a * e, tiny), np.clip((b * f - c * e) / safe(denom), 0, 1), 0.0)
    s = np.where(e > tiny, s, np.clip(-c / safe(a), 0.0, 1.0))  # q is a point
    s = np.where(a > tiny, s, 0.0)  # p is a point
    t = np.where(e > tiny, (b * s + f) / safe(e), 0.0)
    # Re-clamp t and recompute s when t left [0, 1].
    t_c = np.clip(t, 0.0, 1.0)
    s = np.where((t != t_c) & (a > tiny), np.clip((b * t_c - c) / safe(a), 0.0, 1.0), s)
    t = t_c
    diff = (p0 + d1 * s[..., None]) - (q0 + d2 * t[..., None])
    return np.linalg.norm(diff, axis=-1)


@dataclass(frozen=True, eq=False)
class CollisionPairs:
    """Capsule pairs to test: indices into the flat list of (link, capsule) shapes.

    Attributes:
        link: (S,) link index of each shape.
        a, b: (S, 3) segment ends in the link frame [mm].
        radius: (S,) capsule radii [mm].
        first, second: (P,) shape index of each pair's two capsules.
        names: (P,) the two links of each pair.
        group_start: (K + 1,) pairs are sorted by their pair of links; pairs
            ``group_start[k]:group_start[k+1]`` join the same two links (a broad phase
            tests those two links' bounding spheres once).
        link_centre: (n_links, 3) centre of each link's bounding sphere, link frame [mm].
        link_radius: (n_links,) radius of a sphere enclosing every capsule of the link [mm].
    """

    link: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray
    first: np.ndarray
    second: np.ndarray
    names: tuple[tuple[str, str], ...]
    group_start: np.ndarray
    link_centre: np.ndarray
    link_radius: np.ndarray


@cached_per_value
def collision_pairs(hand: Hand) -> CollisionPairs:
    """The capsule pairs of ``hand`` that a self-collision check must test (cached per hand)."""
    shapes = [(i, c) for i, link in enumerate(hand.links) for c in link.collision]
    joined = {frozenset((j.parent, j.child)) for j in hand.joints}
    joined |= {frozenset(p) for p in hand.collision_exclusions}
    names = hand.link_names
    link_of = np.array([i for i, _ in shapes], dtype=np.int64)
    first, second = [], []
    for s, (li, _) in enumerate(shapes):
        for t in range(s + 1, len(shapes)):
            lj = shapes[t][0]
            if li == lj or frozenset((names[li], names[lj])) in joined:
                continue
            first.append(s)
            second.append(t)
    first = np.array(first, dtype=np.int64)
    second = np.array(second, dtype=np.int64)
    a = np.array([c.a for _, c in shapes], dtype=float).reshape(-1, 3)
    b = np.array([c.b for _, c in shapes], dtype=float).reshape(-1, 3)
    radius = np.array([c.radius for _, c in shapes], dtype=float)
    order = np.lexsort((link_of[second], link_of[first])) if first.size else np.zeros(0, dtype=np.int64)
    first, second = first[order], second[order]
    key = link_of[first] * len(hand.links) + link_of[second]
    breaks = np.flatnonzero(np.diff(key)) + 1
    group_start = np.concatenate([[0], breaks, [first.size]] if first.size else [[0]]).astype(np.int64)
    pair_names = tuple((names[link_of[i]], names[link_of[j]]) for i, j in zip(first, second))
    centre, rad = _link_spheres(len(hand.links), link_of, a, b, radius)
    return CollisionPairs(link_of, a, b, radius, first, second, pair_names, group_start, centre, rad)


def _link_spheres(n_links, link_of, a, b, radius) -> tuple[np.ndarray, np.ndarray]:
    """Per link a sphere (link frame) that encloses every capsule of the link."""
    centre = np.zeros((n_links, 3))
    rad = np.zeros(n_links)
    for li in np.unique(link_of):
        own = link_of == li
        ends = np.concatenate([a[own], b[own]])
        centre[li] = 0.5 * (ends.min(axis=0) + ends.max(axis=0))
        rad[li] = np.max(np.linalg.norm(ends - centre[li], axis=1) + np.concatenate([radius[own], radius[own]]))
    return centre, rad


def capsule_clearances(hand: Hand, pose: HandPose) -> tuple[np.ndarray, tuple[tuple[str, str], ...]]:
    """Clearance of every tested capsule pair, (B, P) [mm]; negative means penetration.

    The pairs run through a compiled loop (:func:`_clearances`, numba) with the same
    closed form as :func:`segment_distance`: a few hundred pairs of thousands of
    configurations (the initial-pose samples of a 20-joint hand) take milliseconds.  The
    result itself holds ``B x P`` numbers: for large batches of a hand with many capsules
    use :func:`max_penetration`, whose memory does not grow with ``P``.
    """
    pairs = collision_pairs(hand)
    B = pose.r_palm_link.shape[0]
    if len(pairs.first) == 0:
        return np.zeros((B, 0)), pairs.names
    R = pose.R_palm_link[:, pairs.link]  # (B, S, 3, 3)
    r = pose.r_palm_link[:, pairs.link]  # (B, S, 3)
    a = np.ascontiguousarray(np.einsum("bsij,sj->bsi", R, pairs.a) + r)  # (B, S, 3) segment starts, palm frame
    b = np.ascontiguousarray(np.einsum("bsij,sj->bsi", R, pairs.b) + r)
    return aot(_clearances)(a, b, pairs.radius, pairs.first, pairs.second), pairs.names


try:  # numba is a dependency; without it the same loop runs as (slow) Python
    from numba import njit
except ImportError:  # pragma: no cover
    def njit(*args, **kwargs):
        return args[0] if len(args) == 1 and callable(args[0]) else (lambda f: f)


@njit(cache=True)
def _clamp01(x):
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@njit(cache=True)
def _segment_distance(a, b, k, i, j) -> float:
    """Distance between segments ``a[k, i]-b[k, i]`` and ``a[k, j]-b[k, j]`` (scalar code,
    no temporaries) -- Ericson 5.1.9, the closed form of :func:`segment_distance`."""
    tiny = 1e-12
    d1x, d1y, d1z = b[k, i, 0] - a[k, i, 0], b[k, i, 1] - a[k, i, 1], b[k, i, 2] - a[k, i, 2]
    d2x, d2y, d2z = b[k, j, 0] - a[k, j, 0], b[k, j, 1] - a[k, j, 1], b[k, j, 2] - a[k, j, 2]
    rx, ry, rz = a[k, i, 0] - a[k, j, 0], a[k, i, 1] - a[k, j, 1], a[k, i, 2] - a[k, j, 2]
    aa = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    bb = d1x * d2x + d1y * d2y + d1z * d2z
    if aa <= tiny and e <= tiny:
        s, t = 0.0, 0.0
    elif aa <= tiny:
        s, t = 0.0, _clamp01(f / e)
    elif e <= tiny:
        s, t = _clamp01(-c / aa), 0.0
    else:
        denom = aa * e - bb * bb
        s = _clamp01((bb * f - c * e) / denom) if denom > tiny * max(aa * e, tiny) else 0.0
        t = (bb * s + f) / e
        if t < 0.0 or t > 1.0:
            t = _clamp01(t)
            s = _clamp01((bb * t - c) / aa)
    x = rx + d1x * s - d2x * t
    y = ry + d1y * s - d2y * t
    z = rz + d1z * s - d2z * t
    return math.sqrt(x * x + y * y + z * z)


@njit(cache=True)
def _clearances(a, b, radius, first, second):
    """``a, b (B, S, 3)`` capsule segments, ``radius (S,)``, pairs ``first, second (P,)`` -> (B, P)."""
    B, P = a.shape[0], first.shape[0]
    out = np.empty((B, P))
    for k in range(B):
        for p in range(P):
            i, j = first[p], second[p]
            out[k, p] = _segment_distance(a, b, k, i, j) - radius[i] - radius[j]
    return out


def max_penetration(hand: Hand, pose: HandPose, *, stop_at_first: bool = False) -> np.ndarray:
    """Largest penetration depth over every tested capsule pair, (B,) [mm] (0: no collision).

    Compiled, one configuration at a time, with capsules whose bounding spheres are
    apart skipped: memory does not grow with the number of pairs or the batch.  With
    ``stop_at_first`` each configuration stops at its first penetrating pair (the depth
    is then a lower bound; enough to tell which configurations collide).
    """
    from ._capsules import max_depths

    pairs = collision_pairs(hand)
    B = pose.r_palm_link.shape[0]
    if len(pairs.first) == 0 or B == 0:
        return np.zeros(B)
    R = np.ascontiguousarray(pose.R_palm_link, dtype=float)
    r = np.ascontiguousarray(pose.r_palm_link, dtype=float)
    return max_depths(R, r, pairs, bool(stop_at_first))
