"""Flat arrays for the kernel: a *group* of problems that share one hand and one structure.

A group holds the hand's joint tree, the map from the free unknowns to every joint angle
(couplings followed exactly, idle fingers held), the layout of the unknown vector, and one
row of region data per problem.  Problems of one group differ only in their numbers (the
object regions, the hand regions' centres...), never in their kinds or sizes.

Unknowns ``x`` (one row per state):

``x = (q_free (nf), twist (6), per contact: hand params (k_h), object params (k_o))``

* ``q_free``: the angles that move and are not coupled to another one.  A coupled angle
  is ``ratio * q_source + offset`` exactly, so couplings hold to rounding in every
  answer, and its limits become limits of its source (a box on ``q_free``);
* the twist columns stand for a small motion of the object pose about the problem's
  *pivot* (the mean of its object regions' reference points), see :mod:`._kernel`;
* region parameters: Bézier ``(u, v)`` kept in [0, 1]^2, sphere caps ``(alpha, gamma)``
  kept in their cone, points none.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import InvalidTask
from ...geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from ...hands.model import Hand
from . import _kernel as K

__all__ = ["Group", "region_code", "region_data", "hand_tables", "build_group"]

_BOUND_SHRINK = 1e-12  # rad: derived bounds of coupled angles stay strictly inside


def region_code(region: Region) -> tuple[int, int, int, int]:
    """``(kind, m, n, data size)`` of a region, for the kernel."""
    if isinstance(region, PointRegion):
        return K.K_POINT, 0, 0, K.POINT_SIZE
    if isinstance(region, SphereCap):
        return K.K_CAP, 0, 0, K.CAP_SIZE
    if isinstance(region, BezierRegion):
        m, n = region.patch.degree
        if max(m, n) > K.MAX_DEGREE:
            raise InvalidTask(f"the local solver handles Bézier patches up to degree {K.MAX_DEGREE}, got {m}x{n}")
        return K.K_BEZIER, m, n, 3 * (m + 1) * (n + 1)
    raise InvalidTask(
        f"the local solver handles points, sphere caps and Bézier patches; got a region of kind {region.kind!r}"
    )


_DATA: dict = {}


def region_data(region: Region) -> np.ndarray:
    """The region's numbers in the kernel's layout (see :mod:`._kernel`; cached per region)."""
    hit = _DATA.get(id(region))
    if hit is not None and hit[0] is region:
        return hit[1]
    data = _region_data(region)
    if len(_DATA) > 10000:
        _DATA.clear()
    _DATA[id(region)] = (region, data)
    return data


def _region_data(region: Region) -> np.ndarray:
    if isinstance(region, PointRegion):
        return np.concatenate([region.point, region.normal])
    if isinstance(region, SphereCap):
        e1, e2, m = region.frame.T
        return np.concatenate(
            [region.center, [region.radius], e1, e2, m, [np.cos(region.half_angle), region.half_angle, 0.0]]
        )
    if isinstance(region, BezierRegion):
        return np.asarray(region.patch.control_points, dtype=float).ravel()
    raise InvalidTask(f"unsupported region kind {region.kind!r}")


_REFS: dict = {}


def region_reference_point(region: Region) -> np.ndarray:
    """A representative point of a region (its frame): used for pivots and sizes (cached
    per region: a batch meets the same regions again and again)."""
    hit = _REFS.get(id(region))
    if hit is not None and hit[0] is region:
        return hit[1]
    point = _reference_point(region)
    if len(_REFS) > 10000:
        _REFS.clear()
    _REFS[id(region)] = (region, point)
    return point


def _reference_point(region: Region) -> np.ndarray:
    if isinstance(region, PointRegion):
        return region.point
    if isinstance(region, SphereCap):
        return region.center + region.radius * region.axis
    if isinstance(region, BezierRegion):
        return region.patch.evaluate(0.5, 0.5)[0]
    raise InvalidTask(f"unsupported region kind {region.kind!r}")


def region_size(region: Region) -> float:
    """How far the region's point moves per unit of its parameters [mm]."""
    if isinstance(region, SphereCap):
        return float(region.radius)
    if isinstance(region, BezierRegion):
        lo, hi = region.patch.bounds()
        return float(max(np.linalg.norm(np.asarray(hi) - np.asarray(lo)), 1.0))
    return 1.0


# -- the hand ---------------------------------------------------------------------------
def hand_tables(hand: Hand) -> dict:
    """The joint tree as arrays (cached on the frozen hand)."""
    cached = hand.__dict__.get("_local_tables")
    if cached is not None:
        return cached
    names = hand.link_names
    NJ = len(hand.joints)
    t = {
        "jp": np.array([names.index(j.parent) for j in hand.joints], dtype=np.int64),
        "jc": np.array([names.index(j.child) for j in hand.joints], dtype=np.int64),
        "jkind": np.array([0 if j.kind == "revolute" else 1 for j in hand.joints], dtype=np.int64),
        "joff": np.array(hand.dof_offsets, dtype=np.int64),
        "jP": np.array([j.origin_in_parent for j in hand.joints], dtype=float).reshape(NJ, 3),
        "jQ": np.array([j.origin_in_child for j in hand.joints], dtype=float).reshape(NJ, 3),
        "ju": np.array([j.axis_in_parent for j in hand.joints], dtype=float).reshape(NJ, 3),
        "jR0": np.array([j.R_parent_child_zero for j in hand.joints], dtype=float).reshape(NJ, 3, 3),
        "jv": np.array(
            [j.axis_in_child if j.axis_in_child is not None else np.zeros(3) for j in hand.joints], dtype=float
        ).reshape(NJ, 3),
        "n_links": len(names),
    }
    object.__setattr__(hand, "_local_tables", t)
    return t


def collision_tables(hand: Hand) -> tuple:
    """``(moves, cap_link, cap_a, cap_b, cap_r, pair_i, pair_j)``: the foundation's capsule
    pairs (:func:`~prehension.hands.collision.collision_pairs`) as kernel arrays (cached)."""
    cached = hand.__dict__.get("_local_collision")
    if cached is not None:
        return cached
    from ...hands.collision import collision_pairs
    from ...hands.model import tree_tables

    pairs = collision_pairs(hand)
    out = (
        np.ascontiguousarray(tree_tables(hand)["moves"], dtype=np.bool_),
        np.asarray(pairs.link, dtype=np.int64), np.asarray(pairs.a, dtype=float).reshape(-1, 3),
        np.asarray(pairs.b, dtype=float).reshape(-1, 3), np.asarray(pairs.radius, dtype=float).reshape(-1),
        np.asarray(pairs.first, dtype=np.int64), np.asarray(pairs.second, dtype=np.int64),
    )  # fmt: skip
    object.__setattr__(hand, "_local_collision", out)
    return out


def hand_key(hand: Hand) -> tuple:
    """What makes two hands kinematically the same (regions aside; cached)."""
    cached = hand.__dict__.get("_local_key")
    if cached is not None:
        return cached
    t = hand_tables(hand)
    arrays = tuple(np.round(t[k], 12).tobytes() for k in ("jp", "jc", "jkind", "jP", "jQ", "ju", "jR0", "jv"))
    cpl = tuple((c.dof, c.source, c.ratio, c.offset) for c in hand.couplings)
    key = (hand.link_names, hand.dof_names, arrays, tuple(hand.lower), tuple(hand.upper), cpl)
    object.__setattr__(hand, "_local_key", key)
    return key


def free_dof_map(hand: Hand, active: np.ndarray, idle: np.ndarray):
    """``(free dof indices, dof_free, dof_ratio, dof_offset, q_fixed, lower, upper)``.

    ``q[d] = dof_ratio[d] * q_free[dof_free[d]] + dof_offset[d]`` when ``dof_free[d] >= 0``,
    else ``q[d] = q_fixed[d]``.  The bounds of each free angle are its own limits
    intersected with those its coupled angles impose.
    """
    n = hand.n_dof
    coupled = {hand.dof_index(c.dof): c for c in hand.couplings}
    ratio = np.ones(n)
    offset = np.zeros(n)
    root = np.arange(n)
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
    dof_free = np.full(n, -1, dtype=np.int64)
    for d in range(n):
        if active[d] and root[d] in pos:
            dof_free[d] = pos[root[d]]
    lo = np.array([hand.lower[d] for d in free], dtype=float)
    hi = np.array([hand.upper[d] for d in free], dtype=float)
    for d in range(n):
        j = dof_free[d]
        if j < 0 or free[j] == d:
            continue
        a = (hand.lower[d] - offset[d]) / ratio[d]
        b = (hand.upper[d] - offset[d]) / ratio[d]
        a, b = min(a, b), max(a, b)
        lo[j] = max(lo[j], a + _BOUND_SHRINK)
        hi[j] = min(hi[j], b - _BOUND_SHRINK)
    q_fixed = np.where(dof_free < 0, idle, 0.0)
    ratio = np.where(dof_free >= 0, ratio, 0.0)
    offset = np.where(dof_free >= 0, offset, 0.0)
    return free, dof_free, ratio, offset, q_fixed, lo, hi


# -- a group ----------------------------------------------------------------------------
@dataclass(frozen=True)
class ContactSpec:
    """What the kernel needs to know about one contact (same for every problem)."""

    name: str
    link: str
    hand_kind: int
    hand_m: int
    hand_n: int
    object_kind: int
    object_m: int
    object_n: int
    tip_of: str | None  # finger whose fingertip cap this hand region is (sequence params)


@dataclass(eq=False)
class Group:
    """Everything :func:`._kernel.run_states` takes, plus how to read its answers."""

    hand: Hand
    fingers: tuple[str, ...]
    contacts: tuple[ContactSpec, ...]
    free: list  # dof index of each free unknown
    dof_free: np.ndarray
    dof_ratio: np.ndarray
    dof_offset: np.ndarray
    q_fixed: np.ndarray
    cint: np.ndarray
    cdofs: np.ndarray
    cnd: np.ndarray
    pcols: np.ndarray
    pn: np.ndarray
    anchor: int
    i1: int
    i2: int
    lo: np.ndarray
    hi: np.ndarray
    boxed: np.ndarray
    Dinv: np.ndarray  # (P, nx) inverse scale of each unknown, per problem
    nf: int
    nx: int
    pdata: np.ndarray
    piv_off: int
    pose_names: tuple  # per unknown: its name in an initial-pose sequence, or None
    x_default: np.ndarray  # (nx,) initial unknowns where the sequence says nothing
    extra: dict = field(default_factory=dict)

    @property
    def n_problems(self) -> int:
        return self.pdata.shape[0]

    def q_of(self, x: np.ndarray) -> np.ndarray:
        """Every joint angle (S, n_dof) from unknowns ``x (S, nx)``."""
        x = np.atleast_2d(x)
        qf = x[:, : self.nf]
        idx = np.maximum(self.dof_free, 0)
        q = self.dof_ratio * qf[:, idx] + self.dof_offset
        return np.where(self.dof_free >= 0, q, self.q_fixed)

    def params_of(self, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per contact ``(hand params (S, k_h), object params (S, k_o))``."""
        x = np.atleast_2d(x)
        out = []
        for c in range(len(self.contacts)):
            xh, kh, xo, ko = self.cint[c, K.C_XH], self.cint[c, K.C_KH], self.cint[c, K.C_XO], self.cint[c, K.C_KO]
            out.append((x[:, xh : xh + kh].copy(), x[:, xo : xo + ko].copy()))
        return out

    def kernel_args(self):
        t = hand_tables(self.hand)
        return (
            t["jp"], t["jc"], t["jkind"], t["joff"], t["jP"], t["jQ"], t["ju"], t["jR0"], t["jv"], t["n_links"],
            self.dof_free, self.dof_ratio, self.dof_offset, self.q_fixed,
            self.cint, self.cdofs, self.cnd, self.pcols, self.pn, self.anchor, self.i1, self.i2,
            self.lo, self.hi, self.boxed, self.Dinv, self.nf, *collision_tables(self.hand),
        )  # fmt: skip


def _tip_finger(hand: Hand, link: str, region: Region) -> str | None:
    finger = hand.finger_of_link(link)
    if finger is None or not isinstance(region, SphereCap):
        return None
    return finger if hand.finger(finger).tip_link == link else None


def build_group(
    hand: Hand,
    fingers: tuple[str, ...],
    active: np.ndarray,
    idle: np.ndarray,
    contact_names: list[str],
    hand_regions: list[tuple[str, Region]],
    object_regions: list[Region],
    pdata: np.ndarray,
    piv_off: int,
    object_sizes,
    object_extent,
    joint_scale_mm: float,
    hand_sizes=None,
) -> Group:
    """A group from the regions of its first problem (kinds and bounds) and all problems' data.

    The scales of the unknowns are per problem (``Dinv`` is (P, nx)): a problem's answer
    does not depend on the other problems of its batch.

    Args:
        hand_regions: per contact ``(link, region)`` of the first problem.
        object_regions: per contact the object region of the first problem.
        pdata: (P, nd) region data of every problem, pivot at ``piv_off``.
        object_sizes: (P, C) or (C,): per problem and contact, the object region's size
            [mm per parameter unit].
        object_extent: (P,) or scalar: per problem, the distance from the pivot to the
            farthest object reference point [mm].
        hand_sizes: (P, C) or (C,): per problem and contact, the hand region's size
            [mm per parameter unit] (default: those of ``hand_regions``).
    """
    C = len(contact_names)
    free, dof_free, dratio, doffset, q_fixed, qlo, qhi = free_dof_map(hand, active, idle)
    nf = len(free)
    specs, cint_rows = [], []
    off = 0
    xcol = nf + 6
    lo = [*qlo, *([-np.inf] * 6)]
    hi = [*qhi, *([np.inf] * 6)]
    boxed = [True] * nf + [False] * 6
    scale = [joint_scale_mm] * nf + [1.0] * 6  # object translation and params: per problem, below
    pose_names: list = [hand.dof_names[d] for d in free] + [None] * 6
    x_default = [0.5 * (a + b) for a, b in zip(qlo, qhi)] + [0.0] * 6

    def add_params(region: Region, names):
        nonlocal xcol
        k = region.n_params
        start = xcol
        if k:
            a, b = region.param_bounds()
            if isinstance(region, SphereCap):  # any cap: the widest box (cone kept by projection)
                a, b = np.array([-np.pi, -np.pi / 2]), np.array([np.pi, np.pi / 2])
                if region.half_angle <= np.pi / 2:
                    a, b = region.param_bounds()
            lo.extend(a.tolist())
            hi.extend(b.tolist())
            boxed.extend([isinstance(region, BezierRegion)] * k)
            scale.extend([1.0] * k)
            pose_names.extend(names if names is not None else [None] * k)
            x_default.extend([0.5, 0.5] if isinstance(region, BezierRegion) else [0.0] * k)
        xcol += k
        return start, k

    for c in range(C):
        link, hreg = hand_regions[c]
        oreg = object_regions[c]
        hk, hm, hn, hsize = region_code(hreg)
        ok, om, on, osize = region_code(oreg)
        tip = _tip_finger(hand, link, hreg)
        names = [f"{tip}.tip.alpha", f"{tip}.tip.gamma"] if tip else None
        xh, kh = add_params(hreg, names)
        xo, ko = add_params(oreg, None)
        cint_rows.append([hand.link_index(link), hk, off, hm, hn, ok, off + hsize, om, on, xh, kh, xo, ko])
        off += hsize + osize
        specs.append(ContactSpec(contact_names[c], link, hk, hm, hn, ok, om, on, tip))
    nx = xcol
    cint = np.array(cint_rows, dtype=np.int64).reshape(C, K.N_CINT)
    chains = [hand.chain_dofs(link) for link, _ in hand_regions]
    maxd = max([len(ch) for ch in chains] + [1])
    cdofs = np.zeros((C, maxd), dtype=np.int64)
    cnd = np.zeros(C, dtype=np.int64)
    cols = []
    for c, ch in enumerate(chains):
        cdofs[c, : len(ch)] = ch
        cnd[c] = len(ch)
        s = {int(dof_free[d]) for d in ch if dof_free[d] >= 0}
        s |= set(range(nf, nf + 6))
        s |= set(range(cint[c, K.C_XH], cint[c, K.C_XH] + cint[c, K.C_KH]))
        s |= set(range(cint[c, K.C_XO], cint[c, K.C_XO] + cint[c, K.C_KO]))
        cols.append(s)
    maxp = max(len(s) for s in cols)
    pcols = np.zeros((C, C, maxp), dtype=np.int64)
    pn = np.zeros((C, C), dtype=np.int64)
    for a in range(C):
        for b in range(C):
            common = sorted(cols[a] & cols[b])
            pcols[a, b, : len(common)] = common
            pn[a, b] = len(common)
    anchor, i1, i2 = _anchor_and_pair(hand, specs)
    if hand_sizes is None:
        hand_sizes = [region_size(r) for _, r in hand_regions]
    Dinv = _per_problem_scales(np.array(scale, dtype=float), pdata.shape[0], nf, cint, object_extent, object_sizes, hand_sizes)
    return Group(
        hand, tuple(fingers), tuple(specs), free, dof_free, dratio, doffset, q_fixed,
        cint, cdofs, cnd, pcols, pn, anchor, i1, i2,
        np.array(lo, dtype=float), np.array(hi, dtype=float), np.array(boxed, dtype=np.bool_),
        Dinv, nf, nx, np.ascontiguousarray(pdata, dtype=float), piv_off,
        tuple(pose_names), np.array(x_default, dtype=float),
    )  # fmt: skip


def _per_problem_scales(scale, P: int, nf: int, cint, extent, object_sizes, hand_sizes) -> np.ndarray:
    """``Dinv (P, nx)``: the inverse scale of every unknown, per problem.

    Joint angles and rotation columns share one scale; the object translation is scaled
    by the problem's own object extent (at least 10 mm) and each region's parameters by
    that region's own size, so that solving a problem in a batch or alone is the same.
    """
    C = cint.shape[0]
    S = np.repeat(scale[None], P, axis=0)
    S[:, nf : nf + 3] = np.maximum(np.broadcast_to(np.asarray(extent, dtype=float), (P,)), 10.0)[:, None]
    hs = np.broadcast_to(np.asarray(hand_sizes, dtype=float), (P, C))
    os_ = np.broadcast_to(np.asarray(object_sizes, dtype=float), (P, C))
    for c in range(C):
        xh, kh, xo, ko = cint[c, K.C_XH], cint[c, K.C_KH], cint[c, K.C_XO], cint[c, K.C_KO]
        S[:, xh : xh + kh] = hs[:, c, None]
        S[:, xo : xo + ko] = os_[:, c, None]
    return np.ascontiguousarray(1.0 / S)


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
