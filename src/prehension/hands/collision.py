"""Self-collision of a hand from its capsule collision shapes.

Two links are checked against each other unless a joint joins them directly or the hand
lists the pair in ``collision_exclusions``.  The clearance of two capsules is the distance
between their segments minus the two radii; a negative clearance is a penetration depth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .kinematics import HandPose
from .model import Hand

__all__ = ["CollisionPairs", "collision_pairs", "segment_distance", "capsule_clearances"]


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
    """Capsule pairs to test: indices into the flat list of (link, capsule) shapes."""

    link: np.ndarray  # (S,) link index of each shape
    a: np.ndarray  # (S, 3) segment start in the link frame [mm]
    b: np.ndarray  # (S, 3) segment end in the link frame [mm]
    radius: np.ndarray  # (S,)
    first: np.ndarray  # (P,) shape index of each pair's first capsule
    second: np.ndarray  # (P,)
    names: tuple[tuple[str, str], ...]  # (P,) the two links of each pair


def collision_pairs(hand: Hand) -> CollisionPairs:
    """The capsule pairs of ``hand`` that a self-collision check must test (cached)."""
    cached = hand.__dict__.get("_collision_pairs")
    if cached is not None:
        return cached
    shapes = [(i, c) for i, link in enumerate(hand.links) for c in link.collision]
    joined = {frozenset((j.parent, j.child)) for j in hand.joints}
    joined |= {frozenset(p) for p in hand.collision_exclusions}
    names = hand.link_names
    first, second, pair_names = [], [], []
    for s, (li, _) in enumerate(shapes):
        for t in range(s + 1, len(shapes)):
            lj = shapes[t][0]
            if li == lj or frozenset((names[li], names[lj])) in joined:
                continue
            first.append(s)
            second.append(t)
            pair_names.append((names[li], names[lj]))
    pairs = CollisionPairs(
        np.array([i for i, _ in shapes], dtype=int),
        np.array([c.a for _, c in shapes]).reshape(-1, 3),
        np.array([c.b for _, c in shapes]).reshape(-1, 3),
        np.array([c.radius for _, c in shapes]),
        np.array(first, dtype=int),
        np.array(second, dtype=int),
        tuple(pair_names),
    )
    object.__setattr__(hand, "_collision_pairs", pairs)
    return pairs


def capsule_clearances(hand: Hand, pose: HandPose) -> tuple[np.ndarray, tuple[tuple[str, str], ...]]:
    """Clearance of every tested capsule pair, (B, P) [mm]; negative means penetration.

    The pairs run through a compiled loop (:func:`_clearances`, numba) with the same
    closed form as :func:`segment_distance`: a few hundred pairs of thousands of
    configurations (the initial-pose samples of a 20-joint hand) take milliseconds.
    """
    pairs = collision_pairs(hand)
    B = pose.r_palm_link.shape[0]
    if len(pairs.first) == 0:
        return np.zeros((B, 0)), pairs.names
    R = pose.R_palm_link[:, pairs.link]  # (B, S, 3, 3)
    r = pose.r_palm_link[:, pairs.link]  # (B, S, 3)
    a = np.ascontiguousarray(np.einsum("bsij,sj->bsi", R, pairs.a) + r)  # (B, S, 3) segment starts, palm frame
    b = np.ascontiguousarray(np.einsum("bsij,sj->bsi", R, pairs.b) + r)
    return _clearances(a, b, pairs.radius, pairs.first, pairs.second), pairs.names


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
