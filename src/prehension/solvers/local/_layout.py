"""Flat arrays for the kernel: the hand (:class:`HandArrays`) and a group's layout (:class:`Layout`).

:class:`HandArrays` is built once per hand (:meth:`HandArrays.from_hand`; :func:`hand_arrays`
keeps them in a cache keyed by the hand object, never on the frozen hand).  A *group* is a
set of problems that share one hand and one structure; it holds the map from the free
unknowns to every joint angle (couplings followed exactly, idle fingers held), the layout
of the unknown vector, and one row of region data per problem.

Unknowns ``x`` (one row per state):

``x = (q_free (nf), twist (6), per contact: hand params (k_h), object params (k_o))``

* ``q_free``: the angles that move and are not coupled to another one.  A coupled angle
  is ``ratio * q_source + offset`` exactly, so couplings hold to rounding in every
  answer, and its limits become limits of its source (a box on ``q_free``);
* the twist columns stand for a small motion of the object pose about the problem's
  *pivot* (the mean of its object regions' reference points), see :mod:`._kernel`;
* region parameters: see :mod:`._regions`.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ...errors import InvalidTask
from ...frozen import IdentityCache, cached_per_value
from ...geometry.regions import Region
from ...hands.collision import collision_pairs
from ...hands.kinematics import joint_tables
from ...hands.model import Hand
from ...kernels.chain import JointTables
from . import _regions as RG
from ._penetration import NO_OBJECT, ObjectArrays

__all__ = ["HandArrays", "hand_arrays", "Layout", "Group", "ContactRegions", "build_group", "SIDE_COLUMNS"]

_BOUND_SHRINK = 1e-12  # rad: derived bounds of coupled angles stay strictly inside

# columns of ``Layout.sides[c, side]`` (side 0: the hand's region, 1: the object's)
S_KIND, S_OFF, S_M, S_N, S_X, S_K = range(6)
SIDE_COLUMNS = 6


class HandArrays(NamedTuple):
    """A hand as flat arrays (palm frame, mm, rad); built once per hand.

    ``joints``: the joint tree (:class:`~prehension.kernels.chain.JointTables`, the same
    tables as the foundation's forward kinematics).  Links: ``n_links``, ``moves``
    (n_links, n_dof) whether an angle moves a link.  Capsules
    (:class:`~prehension.hands.collision.CollisionPairs`): ``cap_link`` (S,), ``cap_a``,
    ``cap_b`` (S, 3), ``cap_radius`` (S,), pairs ``pair_first``/``pair_second`` (P,) grouped
    by their two links (``group_start`` (K + 1,)) and each link's bounding sphere
    ``link_centre`` (n_links, 3), ``link_radius`` (n_links,).
    """

    joints: JointTables
    n_links: int
    moves: np.ndarray
    cap_link: np.ndarray
    cap_a: np.ndarray
    cap_b: np.ndarray
    cap_radius: np.ndarray
    pair_first: np.ndarray
    pair_second: np.ndarray
    group_start: np.ndarray
    link_centre: np.ndarray
    link_radius: np.ndarray

    @classmethod
    def from_hand(cls, hand: Hand) -> "HandArrays":
        names = hand.link_names
        f = lambda rows, shape: np.ascontiguousarray(np.array(rows, dtype=float).reshape(shape))  # noqa: E731
        moves = np.zeros((len(names), hand.n_dof), dtype=np.bool_)
        for li, link in enumerate(names):
            moves[li, list(hand.chain_dofs(link))] = True
        pairs = collision_pairs(hand)
        return cls(
            joint_tables(hand), len(names), moves,
            pairs.link.astype(np.int64), f(pairs.a, (-1, 3)), f(pairs.b, (-1, 3)), f(pairs.radius, (-1,)),
            pairs.first.astype(np.int64), pairs.second.astype(np.int64), pairs.group_start.astype(np.int64),
            f(pairs.link_centre, (-1, 3)), f(pairs.link_radius, (-1,)),
        )  # fmt: skip

    def digest(self, hand: Hand) -> str:
        """What makes two hands the same for the kernel (kinematics, limits, couplings, capsules)."""
        h = hashlib.sha1()
        for a in (*self.joints, *self[1:]):
            h.update(np.asarray(a).tobytes())
        h.update(repr((hand.link_names, hand.dof_names, hand.lower.tolist(), hand.upper.tolist(),
                       [(c.dof, c.source, c.ratio, c.offset) for c in hand.couplings])).encode())  # fmt: skip
        return h.hexdigest()


@cached_per_value
def hand_arrays(hand: Hand) -> tuple[HandArrays, str]:
    """``(HandArrays.from_hand(hand), its digest)``, built once per hand object (weak cache)."""
    arrays = HandArrays.from_hand(hand)
    return arrays, arrays.digest(hand)


class Layout(NamedTuple):
    """What the kernel needs to know of a group (shared by its problems).

    Attributes:
        dof_free, dof_ratio, dof_offset, q_fixed: (n_dof,) ``q[d] = ratio * x[dof_free[d]] +
            offset`` when ``dof_free[d] >= 0``, else ``q_fixed[d]``.
        sides: (C, 2, SIDE_COLUMNS) per contact and side (0 hand, 1 object): region kind,
            data offset, degrees ``m``, ``n``, first unknown, number of unknowns.
        link: (C,) link of each contact's hand region.
        chain: (C, maxd) dofs that move that link, ``chain_len`` (C,) how many.
        anchor, pair_a, pair_b: contact placed exactly at the start, and the two whose
            direction fixes the rotation about its normal (-1: none).
        lo, hi: (nx,) bounds of the unknowns; ``boxed`` (nx,) whether the box is a hard limit.
        col_scale: (nx,) ``D^-1``: unknowns are scaled to mm-like units in the step (the
            rotation columns per problem, by its object extent: see ``pivot_offset``).
        nf: number of free angles.
        pivot_offset: where the pivot (3) and the object extent (1) [mm] start in a
            problem's data row (its last four numbers).
    """

    dof_free: np.ndarray
    dof_ratio: np.ndarray
    dof_offset: np.ndarray
    q_fixed: np.ndarray
    sides: np.ndarray
    link: np.ndarray
    chain: np.ndarray
    chain_len: np.ndarray
    anchor: int
    pair_a: int
    pair_b: int
    lo: np.ndarray
    hi: np.ndarray
    boxed: np.ndarray
    col_scale: np.ndarray
    nf: int
    pivot_offset: int


@dataclass(frozen=True)
class ContactSpec:
    """One contact of a group (the same for every problem)."""

    name: str
    link: str
    tip_of: str | None  # finger whose fingertip cap this hand region is (sequence params)


@dataclass(frozen=True, eq=False)
class Group:
    """Problems of one hand and one structure: the kernel's inputs and how to read its answers.

    Attributes:
        hand, arrays: the hand and its :class:`HandArrays`.
        layout: the :class:`Layout`.
        pdata: (P, nd) region data of every problem, pivot at ``layout.pivot_offset``.
        free: dof index of each free angle.
        contacts: per contact its :class:`ContactSpec`.
        pose_names: per unknown, its name in an initial-pose sequence, or ``None``.
        x_default: (nx,) initial unknowns where the sequence says nothing.
        obj: the object's solid as the kernel reads it (:class:`._penetration.ObjectArrays`;
            inactive for point problems and objects that do not collide).  The problems
            of a group share it (:func:`.problems.structure_key`).
    """

    hand: Hand
    arrays: HandArrays
    layout: Layout
    pdata: np.ndarray
    free: tuple[int, ...]
    contacts: tuple[ContactSpec, ...]
    pose_names: tuple
    x_default: np.ndarray
    obj: ObjectArrays = NO_OBJECT

    @property
    def n_problems(self) -> int:
        return self.pdata.shape[0]

    @property
    def nx(self) -> int:
        return self.x_default.shape[0]

    @property
    def nf(self) -> int:
        return self.layout.nf

    def with_data(self, pdata: np.ndarray) -> "Group":
        """The same group for other problems of the same structure."""
        return Group(self.hand, self.arrays, self.layout, np.ascontiguousarray(pdata, dtype=float), self.free,
                     self.contacts, self.pose_names, self.x_default, self.obj)  # fmt: skip

    def q_of(self, x: np.ndarray) -> np.ndarray:
        """Every joint angle (S, n_dof) [rad] from unknowns ``x (S, nx)``."""
        L = self.layout
        x = np.atleast_2d(x)
        q = L.dof_ratio * x[:, np.maximum(L.dof_free, 0)] + L.dof_offset
        return np.where(L.dof_free >= 0, q, L.q_fixed)

    def params_of(self, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per contact ``(hand params (S, k_h), object params (S, k_o))``."""
        x = np.atleast_2d(x)
        spans = _spans(self.layout)  # per contact [[h0, hk], [o0, ok]]
        return [(x[:, h0 : h0 + hk].copy(), x[:, o0 : o0 + ok].copy()) for (h0, hk), (o0, ok) in spans]


_SPANS = IdentityCache()  # a layout serves every group of its structure


def _spans(layout: Layout) -> list:
    """``layout.sides[:, :, [S_X, S_K]].tolist()``, once per layout."""
    return _SPANS.get((layout,), None, lambda: layout.sides[:, :, [S_X, S_K]].tolist())


# -- building a group --------------------------------------------------------------------------
def free_dof_map(hand: Hand, active: np.ndarray, idle: np.ndarray):
    """``(free dof indices, dof_free, dof_ratio, dof_offset, q_fixed, lower, upper)``.

    ``q[d] = dof_ratio[d] * q_free[dof_free[d]] + dof_offset[d]`` when ``dof_free[d] >= 0``,
    else ``q[d] = q_fixed[d]``.  The bounds of each free angle are its own limits
    intersected with those its coupled angles impose.
    """
    n = hand.n_dof
    coupled = {hand.dof_index(c.dof): c for c in hand.couplings}
    ratio, offset, root = np.ones(n), np.zeros(n), np.arange(n)
    for d in range(n):  # follow chains of couplings to their root
        r, o, cur, seen = 1.0, 0.0, d, set()
        while cur in coupled:
            if cur in seen:
                raise InvalidTask(f"couplings form a cycle through {hand.dof_names[d]!r}")
            seen.add(cur)
            c = coupled[cur]
            r, o = r * c.ratio, r * c.offset + o
            cur = hand.dof_index(c.source)
        ratio[d], offset[d], root[d] = r, o, cur
    free = [d for d in range(n) if active[d] and d not in coupled]
    pos = {d: i for i, d in enumerate(free)}
    dof_free = np.array([pos.get(root[d], -1) if active[d] else -1 for d in range(n)], dtype=np.int64)
    lo = np.array([hand.lower[d] for d in free], dtype=float)
    hi = np.array([hand.upper[d] for d in free], dtype=float)
    for d in range(n):
        j = dof_free[d]
        if j < 0 or free[j] == d:
            continue
        a, b = sorted(((hand.lower[d] - offset[d]) / ratio[d], (hand.upper[d] - offset[d]) / ratio[d]))
        lo[j] = max(lo[j], a + _BOUND_SHRINK)
        hi[j] = min(hi[j], b - _BOUND_SHRINK)
    q_fixed = np.where(dof_free < 0, idle, 0.0)
    return free, dof_free, np.where(dof_free >= 0, ratio, 0.0), np.where(dof_free >= 0, offset, 0.0), q_fixed, lo, hi


class _Unknowns:
    """The unknown vector, built column by column: bounds, scales, start values, names."""

    def __init__(self, qlo, qhi, joint_scale_mm, names):
        nf = len(qlo)
        self.lo = [*qlo, *([-np.inf] * 6)]
        self.hi = [*qhi, *([np.inf] * 6)]
        self.boxed = [True] * nf + [False] * 6
        self.scale = [joint_scale_mm] * nf + [10.0] * 3 + [1.0] * 3  # rotations: per problem
        self.names = list(names) + [None] * 6
        self.start = [0.5 * (a + b) for a, b in zip(qlo, qhi)] + [0.0] * 6

    def add(self, region: Region, size_mm: float, names=None) -> tuple[int, int]:
        lo, hi, boxed, start = RG.unknown_box(region)
        first, k = len(self.lo), len(lo)
        self.lo += lo.tolist()
        self.hi += hi.tolist()
        self.boxed += [boxed] * k
        self.scale += [size_mm] * k
        self.names += list(names) if names is not None else [None] * k
        self.start += start.tolist()
        return first, k


def _tip_finger(hand: Hand, link: str, kind: int) -> str | None:
    """The finger whose fingertip cap a hand region of ``kind`` (the local stage's code,
    :func:`._regions.code`) on ``link`` is, or None."""
    finger = hand.finger_of_link(link)
    if finger is None or kind != RG.K_CAP:
        return None
    return finger if hand.finger(finger).tip_link == link else None


@dataclass(frozen=True)
class ContactRegions:
    """One contact of a group as its first problem has it: what :func:`build_group` lays out.

    Attributes:
        name: the contact's name.
        link: the link of its hand region.
        hand_region, object_region: its two regions (their kinds and degrees fix the layout).
        object_size: the object region's size [mm per parameter unit] (the scale of its
            parameters in the step).
    """

    name: str
    link: str
    hand_region: Region
    object_region: Region
    object_size: float


def build_group(hand: Hand, active: np.ndarray, idle: np.ndarray, contacts: list[ContactRegions], pdata: np.ndarray,
                joint_scale_mm: float) -> Group:  # fmt: skip
    """A group from the regions of its first problem (kinds and sizes) and every problem's data.

    Args:
        active, idle: (n_dof,) angles that move, and the held value of the others [rad].
        contacts: per contact its :class:`ContactRegions` (of the first problem).
        pdata: (P, nd) region data of every problem (hand, object per contact), then the
            pivot (3) and the object's extent (distance from the pivot to the farthest
            object reference point) [mm].
        joint_scale_mm: weight of one radian in the step [mm].
    """
    arrays, _ = hand_arrays(hand)
    free, dof_free, ratio, offset, q_fixed, qlo, qhi = free_dof_map(hand, active, idle)
    unknowns = _Unknowns(qlo, qhi, joint_scale_mm, [hand.dof_names[d] for d in free])
    sides = np.zeros((len(contacts), 2, SIDE_COLUMNS), dtype=np.int64)
    specs, off = [], 0
    for c, contact in enumerate(contacts):
        codes = (RG.code(contact.hand_region), RG.code(contact.object_region))
        tip = _tip_finger(hand, contact.link, codes[0][0])
        names = [f"{tip}.tip.alpha", f"{tip}.tip.gamma"] if tip else None
        sizes = ((contact.hand_region, RG.size(contact.hand_region), names), (contact.object_region, contact.object_size, None))
        for s, ((region, size, nm), (kind, m, n, nd)) in enumerate(zip(sizes, codes)):
            x0, k = unknowns.add(region, size, nm)
            sides[c, s] = (kind, off, m, n, x0, k)
            off += nd
        specs.append(ContactSpec(contact.name, contact.link, tip))
    hand_regions = [(contact.link, contact.hand_region) for contact in contacts]
    links = np.array([hand.link_index(link) for link, _ in hand_regions], dtype=np.int64)
    chain, chain_len = _chains(hand, hand_regions)
    anchor, pa, pb = _anchor_and_pair(hand, specs)
    layout = Layout(
        dof_free, ratio, offset, q_fixed, sides, links, chain, chain_len, anchor, pa, pb,
        np.array(unknowns.lo), np.array(unknowns.hi), np.array(unknowns.boxed, dtype=np.bool_),
        1.0 / np.array(unknowns.scale), len(free), off,
    )  # fmt: skip
    return Group(hand, arrays, layout, np.ascontiguousarray(pdata, dtype=float), tuple(free), tuple(specs),
                 tuple(unknowns.names), np.array(unknowns.start))  # fmt: skip


def _chains(hand, hand_regions):
    """Per contact the dofs that move its link: ``(chain (C, maxd), chain_len (C,))``."""
    C = len(hand_regions)
    chains = [hand.chain_dofs(link) for link, _ in hand_regions]
    chain = np.zeros((C, max([len(ch) for ch in chains] + [1])), dtype=np.int64)
    chain_len = np.array([len(ch) for ch in chains], dtype=np.int64)
    for c, ch in enumerate(chains):
        chain[c, : len(ch)] = ch
    return chain, chain_len


def _anchor_and_pair(hand: Hand, specs) -> tuple[int, int, int]:
    """The contact whose hold places the object (the opposing finger's, the thumb as in the
    paper: :attr:`Hand.opposing_finger`; else the palm's; else the first) and the two
    contacts whose direction fixes ``psi`` (index and ring as in the paper; else the first
    and last others; -1 when there are fewer)."""
    fingers = [hand.finger_of_link(s.link) for s in specs]
    anchor = next((i for i, f in enumerate(fingers) if f is not None and f == hand.opposing_finger), None)
    if anchor is None:
        anchor = next((i for i, s in enumerate(specs) if s.link == hand.palm), 0)
    others = [i for i in range(len(specs)) if i != anchor]
    if "index" in fingers and "ring" in fingers:
        i1, i2 = fingers.index("index"), fingers.index("ring")
        if anchor not in (i1, i2):
            return anchor, i1, i2
    if len(others) >= 2:
        return anchor, others[0], others[-1]
    return anchor, -1, -1
