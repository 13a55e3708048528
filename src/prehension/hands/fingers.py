"""Fingers found in a kinematic tree, and named from the hand's geometry.

**Chains.**  A finger is the serial chain that ends at a leaf link, starting below the
nearest link where the tree branches (or below the palm).  Links with several children
other than the palm (the Schunk SVH's second palm part, which carries the ring and little
fingers) belong to no finger: they move with the fingers below them.

**Names** (:func:`finger_names`):

1. when the chains' link names share a stem per finger and those stems already are
   ``thumb``/``index``/``middle``/``ring``/``little``, they are kept;
2. else, when the geometry says so, the finger that **opposes** the others is the
   thumb and the others are, in order along the line of their bases starting from the
   thumb's side, ``index``, ``middle``, ``ring``, ``little``.  A finger's *opposition
   score* is the mean cosine of its pad direction with the other fingers', averaged over
   the closures ``s = 0.2, 0.4, ..., 1`` (every angle at ``lower + s (upper - lower)``,
   couplings applied).  The finger with the lowest score opposes the others when that
   score is below ``0.5`` and below every other finger's by at least ``0.3``; at least
   three fingers and at most four others are needed.  (On the SA, SVH and Allegro hands
   the thumb scores about 0.0 and the others about 0.65.)
3. else each finger is named after the common stem of its link names when that says
   more than the stem shared by the whole hand (``ff_proximal``, ``ff_distal`` -> ``ff``),
   else after its first link.
"""

from __future__ import annotations

import os
from collections import defaultdict, deque

import numpy as np

from .kinematics import forward_kinematics
from .model import Finger, Hand

__all__ = [
    "finger_chains", "finger_names", "closure", "mid_range", "opposition_scores", "CLOSURES", "CANONICAL",
    "OPPOSITION_MAX", "OPPOSITION_MARGIN",
]  # fmt: skip

CANONICAL = ("thumb", "index", "middle", "ring", "little")
OPPOSITION_MAX = 0.5  # the thumb's mean pad cosine with the others must be below this
OPPOSITION_MARGIN = 0.3  # ... and below every other finger's by this much
CLOSURES = (0.2, 0.4, 0.6, 0.8, 1.0)
_SEPARATORS = "_-. /:"


def finger_chains(palm: str, parent_child: list[tuple[str, str]]) -> list[list[str]]:
    """Leaf chains, each from below its nearest branching ancestor (or the palm) to the leaf,
    in breadth-first order of their first links."""
    children: dict[str, list[str]] = defaultdict(list)
    for parent, child in parent_child:
        children[parent].append(child)
    chains, starts = [], deque(children[palm])
    while starts:
        chain = [starts.popleft()]
        while len(children[chain[-1]]) == 1:
            chain.append(children[chain[-1]][0])
        if children[chain[-1]]:  # a branch: its children start new chains, and the links
            starts.extend(children[chain[-1]])  # down to it move with the fingers below
            continue
        chains.append(chain)
    return chains


def _stem(names: list[str]) -> str:
    """Common prefix of ``names`` cut at a separator, without trailing separators."""
    prefix = os.path.commonprefix(names)
    if not all(len(n) == len(prefix) or n[len(prefix)] in _SEPARATORS for n in names):
        prefix = prefix[: max(prefix.rfind(c) for c in _SEPARATORS) + 1]
    return prefix.rstrip(_SEPARATORS)


def _unique(names: list[str]) -> list[str]:
    out = list(names)
    for i, n in enumerate(names):
        k = 2
        while out.count(out[i]) > 1:
            out[i] = f"{n}_{k}"
            k += 1
    return out


def _link_names(chains: list[list[str]]) -> list[str]:
    """Step 3: the informative stem of each chain, else its first link."""
    hand_stem = _stem([link for chain in chains for link in chain]) if chains else ""
    names = []
    for chain in chains:
        stem = _stem(chain) if len(chain) > 1 else ""
        names.append(stem if stem and stem != hand_stem else chain[0])
    return _unique(names)


def closure(hand: Hand, s: float) -> np.ndarray:
    """(n_dof,) every angle at ``lower + s (upper - lower)``, couplings applied [rad]."""
    q = hand.lower + s * (hand.upper - hand.lower)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return q


def mid_range(hand: Hand) -> np.ndarray:
    """(n_dof,) every angle at the middle of its range, couplings applied [rad]."""
    return closure(hand, 0.5)


def opposition_scores(pads: np.ndarray) -> np.ndarray:
    """Per finger, the mean cosine of its pad direction with the others', averaged over
    closures: ``pads (S, F, 3)`` unit vectors -> (F,)."""
    cos = np.einsum("sfi,sgi->sfg", pads, pads)  # (S, F, F)
    F = pads.shape[1]
    return ((cos.sum(axis=2) - np.einsum("sff->sf", cos)) / (F - 1)).mean(axis=0)


def _thumb(pads: np.ndarray) -> int | None:
    if not 3 <= pads.shape[1] <= 5:
        return None
    score = opposition_scores(pads)
    order = np.argsort(score)
    best, second = score[order[0]], score[order[1]]
    return int(order[0]) if best < OPPOSITION_MAX and second - best >= OPPOSITION_MARGIN else None


def _order_from_thumb(bases: np.ndarray, tips: np.ndarray, thumb_tips: np.ndarray) -> np.ndarray:
    """Indices of the other fingers along the line of their bases (``(K, 3)``), starting at
    the end whose distal joint lies nearer the thumb's over the closures (``tips (S, K, 3)``,
    ``thumb_tips (S, 3)``): the thumb's base may sit far below the line, so its own
    projection does not tell the side."""
    if len(bases) == 1:
        return np.zeros(1, dtype=int)
    centre = bases.mean(axis=0)
    t = (bases - centre) @ np.linalg.svd(bases - centre)[2][0]
    order = np.argsort(t, kind="stable")
    near = np.linalg.norm(tips - thumb_tips[:, None, :], axis=2).mean(axis=0)  # (K,)
    return order if near[order[0]] <= near[order[-1]] else order[::-1]


def finger_names(hand: Hand, chains: list[list[str]], pads: np.ndarray | None) -> tuple[list[str], int | None, str]:
    """(names, index of the opposing finger or None, a note saying how they were named).

    Args:
        hand: the hand (kinematics only) whose fingers the chains are.
        chains: link chains of the fingers.
        pads: (S, F, 3) each finger's pad direction in the palm frame at each of the
            :data:`CLOSURES` (None when some finger's is unknown).
    """
    stems = _link_names(chains)
    if set(stems) <= set(CANONICAL):
        thumb = stems.index("thumb") if "thumb" in stems else None
        return stems, thumb, "fingers named after their links"
    thumb = _thumb(pads) if pads is not None else None
    others = [i for i in range(len(chains)) if i != thumb]
    if thumb is None or len(others) > 4:
        return stems, None, "no finger opposes the others clearly: fingers named after their links"
    pose = forward_kinematics(hand, np.array([closure(hand, s) for s in CLOSURES]))
    at = lambda i, k: pose.r_palm_link[:, hand.link_index(chains[i][k])]  # noqa: E731  (S, 3)
    bases = np.array([at(i, 0)[0] for i in others])
    order = _order_from_thumb(bases, np.stack([at(i, -1) for i in others], axis=1), at(thumb, -1))
    names = list(stems)
    names[thumb] = "thumb"
    for rank, k in enumerate(order):
        names[others[k]] = CANONICAL[1 + rank]
    was = ", ".join(f"{new} ({old})" for new, old in zip(names, stems) if new != old)
    return names, thumb, f"fingers named from the geometry (the thumb opposes the others): {was}"


def make_fingers(chains: list[list[str]], names: list[str]) -> list[Finger]:
    return [Finger(n, tuple(chain)) for n, chain in zip(names, chains)]
