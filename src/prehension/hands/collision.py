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

from ..frozen import cached_per_value
from ..kernels.aot import aot
from ..kernels.jit import njit
from ..kernels.segments import CAPSULE_EPS, segment_distances, segment_params_xyz
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

    The closed form of :func:`prehension.kernels.segments.segment_params` (Ericson, *Real-Time
    Collision Detection*, sec. 5.1.9; every degenerate case -- points, parallel segments --
    handled by clamping), over the broadcast leading axes.
    """
    arrays = np.broadcast_arrays(*(np.asarray(p, dtype=float) for p in (p0, p1, q0, q1)))
    shape = arrays[0].shape[:-1]
    flat = [np.ascontiguousarray(a.reshape(-1, 3)) for a in arrays]
    return aot(segment_distances)(*flat).reshape(shape)


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

    The pairs run through a compiled loop (:func:`_clearances`, numba) with the closed form
    of :func:`segment_distance`: a few hundred pairs of thousands of
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


@njit(cache=True)
def _clearances(a, b, radius, first, second):
    """``a, b (B, S, 3)`` capsule segments, ``radius (S,)``, pairs ``first, second (P,)`` -> (B, P)."""
    B, P = a.shape[0], first.shape[0]
    out = np.empty((B, P))
    for k in range(B):
        for p in range(P):
            i, j = first[p], second[p]
            d2 = segment_params_xyz(a[k, i, 0], a[k, i, 1], a[k, i, 2], b[k, i, 0], b[k, i, 1], b[k, i, 2],
                                    a[k, j, 0], a[k, j, 1], a[k, j, 2], b[k, j, 0], b[k, j, 1], b[k, j, 2], CAPSULE_EPS)[0]
            out[k, p] = math.sqrt(d2) - radius[i] - radius[j]
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
