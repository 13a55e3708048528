"""Self-collision of a hand from its capsule collision shapes.

Two links are checked against each other unless a joint joins them directly or the hand
lists the pair in ``collision_exclusions``.  The clearance of two capsules is the distance
between their segments minus the two radii; a negative clearance is a penetration depth.
"""

from __future__ import annotations

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
    """Clearance of every tested capsule pair, (B, P) [mm]; negative means penetration."""
    pairs = collision_pairs(hand)
    B = pose.r_palm_link.shape[0]
    if len(pairs.first) == 0:
        return np.zeros((B, 0)), pairs.names
    R = pose.R_palm_link[:, pairs.link]  # (B, S, 3, 3)
    r = pose.r_palm_link[:, pairs.link]  # (B, S, 3)
    a = np.einsum("bsij,sj->bsi", R, pairs.a) + r
    b = np.einsum("bsij,sj->bsi", R, pairs.b) + r
    dist = segment_distance(a[:, pairs.first], b[:, pairs.first], a[:, pairs.second], b[:, pairs.second])
    return dist - pairs.radius[pairs.first] - pairs.radius[pairs.second], pairs.names
