"""Rigorous bounds on how far apart two points of a hand can be (its *span*).

The complete solver adds redundant constraints ``|o_a - o_b| <= span_ab`` between contact
points; the tighter ``span_ab``, the sooner a task whose object regions lie beyond the
hand's reach is certified infeasible.  Summing link lengths along the chains gives a valid
but loose bound (540 mm between the SA hand's thumb and index tips, whose true span is
about 206 mm).  :func:`max_point_distance` computes a bound within ``tol_mm`` of the true
maximum by branch and bound over the joint angles:

* the joints above the deepest link common to both chains move both points rigidly, so
  they do not change the distance and are left out;
* on a box of angles with centre ``q_c`` and half-widths ``h``, a point moves at most
  ``sum_k R_k h_k`` away from its position at ``q_c``, where ``R_k`` bounds the distance
  from joint ``k``'s centre to the point over *all* configurations (a rotation by ``dt``
  about an axis through the joint centre moves the point along an arc of length at most
  ``R_k |dt|``; integrate along a coordinate path);
* so ``|p_a(q) - p_b(q)| <= |p_a(q_c) - p_b(q_c)| + sum_k (R^a_k + R^b_k) h_k``;
* the same argument bounds second derivatives: ``|d2 p / dt_k dt_l| <= R_m`` with ``m`` the
  more distal of the two joints, so with ``d = p_a - p_b`` and its Jacobian ``J`` at
  ``q_c``, ``|d(q)| <= |d + J D| + 1/2 sum_kl M_kl h_k h_l`` for ``|D_k| <= h_k``, and
  ``|d + J D|^2 <= |d|^2 + 2 sum_k |d . J_k| h_k + (sum_k |J_k| h_k)^2``.  Near the maximum
  ``d . J_k`` vanishes, so this bound converges quadratically;
* boxes are split through the angle with the largest share of that bound, until no box
  can beat the best distance seen by more than ``tol_mm`` (or a box budget runs out: the
  bound is then looser, never invalid).

Coupled angles follow their source inside the chains (the bound only needs a superset of
the reachable configurations: a coupled angle whose source is outside the chains is
treated as free within its limits, and limits of coupled angles are not imposed).
"""

from __future__ import annotations

import hashlib
import heapq
from dataclasses import dataclass

import numpy as np

from ..deadline import current_deadline, passed
from ..geometry.rotations import axis_angle_to_matrix
from .model import Hand, Joint

__all__ = ["PairKinematics", "SpanBound", "chain_joints", "lever_arms_mm", "max_point_distance", "pair_kinematics", "span_bound_mm"]

_ROUNDING = 1e-9  # relative outward margin for floating-point rounding


@dataclass(frozen=True)
class SpanBound:
    """Result of :func:`max_point_distance`.

    Attributes:
        upper_mm: a proven upper bound on the distance [mm].
        lower_mm: the largest distance found at a configuration (a lower bound).
        boxes: boxes of angles evaluated.
    """

    upper_mm: float
    lower_mm: float
    boxes: int


def chain_joints(hand: Hand, link: str) -> list[Joint]:
    """The joints from the palm to ``link``, palm first."""
    out, joint = [], hand.joint_of_link(link)
    while joint is not None:
        out.insert(0, joint)
        joint = hand.joint_of_link(joint.parent)
    return out


def lever_arms_mm(chain: list[Joint], point_in_link: np.ndarray) -> list[float]:
    """Per joint of ``chain``: a bound on the distance [mm] from its centre to a point
    fixed in the chain's last link, valid in every configuration."""
    arms: list[float] = []
    reach = 0.0
    target = np.asarray(point_in_link, dtype=float)
    for joint in reversed(chain):
        reach += float(np.linalg.norm(target - joint.origin_in_child))
        arms.insert(0, reach)
        target = joint.origin_in_parent  # the next centre up, fixed in this joint's parent
    return arms


def _common_prefix(a: list[Joint], b: list[Joint]) -> int:
    k = 0
    while k < min(len(a), len(b)) and a[k] is b[k]:
        k += 1
    return k


@dataclass(frozen=True)
class _Problem:
    """The angles of a span problem: which dofs vary, their bounds and limits."""

    sources: np.ndarray  # dof index of each searched angle
    weights_mm: np.ndarray  # per searched angle: sum of lever arms of the dofs it drives
    curvature_mm: np.ndarray  # (n, n) bounds M on the second derivatives of p_a - p_b
    lower: np.ndarray
    upper: np.ndarray
    driven: tuple  # (dof, source position, ratio, offset) for every chain dof


def _problem(hand: Hand, chains: list[dict[int, float]]) -> _Problem:
    """Searched angles for the dofs of ``chains`` (per point: ``{dof: lever arm [mm]}``),
    couplings folded in."""
    arms: dict[int, float] = {}
    for chain in chains:
        for dof, arm in chain.items():
            arms[dof] = arms.get(dof, 0.0) + arm
    coupling = {hand.dof_index(c.dof): c for c in hand.couplings}
    sources: list[int] = []
    driven = []
    for dof in sorted(arms):
        c = coupling.get(dof)
        src, ratio, offset = dof, 1.0, 0.0
        if c is not None and hand.dof_index(c.source) in arms:
            src, ratio, offset = hand.dof_index(c.source), c.ratio, c.offset
        if src not in sources:
            sources.append(src)
        driven.append((dof, sources.index(src), ratio, offset))
    weights = np.zeros(len(sources))
    for dof, pos, ratio, _ in driven:
        weights[pos] += abs(ratio) * arms[dof]
    curvature = np.zeros((len(sources), len(sources)))
    for chain in chains:  # d2 p / dt_d dt_e: at most the more distal joint's lever arm
        for d, pd, rd, _ in driven:
            for e, pe, re, _ in driven:
                if d in chain and e in chain:
                    curvature[pd, pe] += abs(rd * re) * min(chain[d], chain[e])
    src = np.array(sources, dtype=int)
    return _Problem(src, weights, curvature, hand.lower[src], hand.upper[src], tuple(driven))


def max_point_distance(
    hand: Hand,
    link_a: str,
    point_a_mm,
    link_b: str | None = None,
    point_b_mm=None,
    *,
    tol_mm: float = 1.0,
    max_boxes: int = 200_000,
    deadline: float | None = None,
) -> SpanBound:
    """A proven upper bound on ``max_q |p_a(q) - p_b(q)|`` over the joint limits.

    ``p_a`` is the point ``point_a_mm`` fixed in link ``link_a``; ``p_b`` likewise, or the
    palm origin when ``link_b`` is None.  The bound is within ``tol_mm`` of the maximum
    unless ``max_boxes`` runs out or ``deadline`` (a :func:`time.perf_counter` instant)
    passes first (then it is looser, never invalid).
    """
    pair = pair_kinematics(hand, link_a, point_a_mm, link_b, point_b_mm)
    return _branch_and_bound(pair.problem, pair.difference, tol_mm, max_boxes, deadline=deadline)


@dataclass(frozen=True, eq=False)
class PairKinematics:
    """Two points fixed in two links as functions of the angles that move them relative to
    each other (the chains below their deepest common link), in that common link's frame.

    Attributes:
        problem: the searched angles (:attr:`sources`, their limits, couplings folded in)
            and the bounds on the second derivatives of ``p_a - p_b`` (``curvature_mm``).
        rotation_curvature: ``(2, n, n)``: for a unit vector fixed in link a (index 0) or
            b (1), a bound on ``|d2 v / d s_k d s_l|`` (each pair of joint angles of the
            chain contributes at most 1, times the coupling ratios).
    """

    problem: _Problem
    rotation_curvature: np.ndarray
    chains: tuple  # ((joints, dof offsets, point) of a, of b)
    base: np.ndarray  # (n_dof,) angles of the dofs outside the chains (unused by them)
    gather: np.ndarray  # (n_dof, n): d q / d angles

    def angles_to_q(self, angles: np.ndarray) -> np.ndarray:
        """``angles (B, n) -> q (B, n_dof)`` [rad] (dofs outside the chains at ``base``)."""
        q = np.repeat(self.base[None], len(angles), axis=0)
        for dof, pos, ratio, offset in self.problem.driven:
            q[:, dof] = ratio * angles[:, pos] + offset
        return q

    def evaluate(self, angles: np.ndarray) -> tuple[np.ndarray, ...]:
        """``angles (B, n) -> (d, J, R_a, W_a, R_b, W_b)``: ``d = p_a - p_b`` (B, 3) [mm], its
        Jacobian (B, 3, n) [mm/rad], the links' rotations (B, 3, 3) and the angular
        velocities of the links per angle (B, 3, n), all in the common link's frame."""
        q = self.angles_to_q(angles)
        (ja, oa, pa_link), (jb, ob, pb_link) = self.chains
        n_dof = len(self.base)
        pa, Ja, Ra, Wa = _chain_point(ja, oa, pa_link, q, n_dof)
        pb, Jb, Rb, Wb = _chain_point(jb, ob, pb_link, q, n_dof)
        g = self.gather
        return pa - pb, (Ja - Jb) @ g, Ra, Wa @ g, Rb, Wb @ g

    def difference(self, angles: np.ndarray):
        """``angles (B, n) -> (d (B, 3), J (B, 3, n))``."""
        d, J, *_ = self.evaluate(angles)
        return d, J

    def distance_upper_mm(self, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Upper bounds ``(B,)`` [mm] of ``|p_a - p_b|`` over boxes of angles ``(B, n)`` (the
        span search's bound, see the module docstring; not yet padded for rounding), and
        each angle's share of it ``(B, n)`` (the span search's splitting score)."""
        half = 0.5 * (upper - lower)
        d, J = self.difference(0.5 * (lower + upper))
        score = (np.maximum(np.linalg.norm(J, axis=1), 1e-3 * self.problem.weights_mm)
                 + 0.5 * half @ self.problem.curvature_mm) * (upper - lower)  # fmt: skip
        return _bounds(self.problem, d, J, half), score


def pair_kinematics(hand: Hand, link_a: str, point_a_mm, link_b: str | None = None, point_b_mm=None) -> PairKinematics:
    """:class:`PairKinematics` of the point ``point_a_mm`` of ``link_a`` and ``point_b_mm`` of
    ``link_b`` (default: the palm origin)."""
    point_a = np.asarray(point_a_mm, dtype=float)
    link_b = hand.palm if link_b is None else link_b
    point_b = np.zeros(3) if point_b_mm is None else np.asarray(point_b_mm, dtype=float)
    chain_a, chain_b = chain_joints(hand, link_a), chain_joints(hand, link_b)
    k = _common_prefix(chain_a, chain_b)
    chains = []
    for chain, point in ((chain_a, point_a), (chain_b, point_b)):
        own: dict[int, float] = {}
        for joint, arm in list(zip(chain, lever_arms_mm(chain, point)))[k:]:
            first = hand.dof_offsets[hand.joints.index(joint)]
            own.update({dof: arm for dof in range(first, first + joint.n_dof)})
        chains.append(own)
    problem = _problem(hand, chains)
    gather = np.zeros((hand.n_dof, len(problem.sources)))  # d q / d angles
    for dof, pos, ratio, _ in problem.driven:
        gather[dof, pos] = ratio
    rot = np.zeros((2, len(problem.sources), len(problem.sources)))
    for side, chain in enumerate(chains):
        for d, pd, rd, _ in problem.driven:
            for e, pe, re, _ in problem.driven:
                if d in chain and e in chain:
                    rot[side, pd, pe] += abs(rd * re)
    offsets = {id(j): off for j, off in zip(hand.joints, hand.dof_offsets)}
    rest = [(tuple(c[k:]), tuple(offsets[id(j)] for j in c[k:]), p) for c, p in ((chain_a, point_a), (chain_b, point_b))]
    base = np.clip(np.zeros(hand.n_dof), hand.lower, hand.upper)
    return PairKinematics(problem, rot, tuple(rest), base, gather)


def _chain_point(joints, offsets, point: np.ndarray, q: np.ndarray, n: int):
    """Point fixed in the last link of ``joints`` (B, 3), d point / d q (B, 3, n_dof), the
    link's rotation (B, 3, 3) and its angular velocity per dof (B, 3, n_dof), in the frame
    of the first joint's parent (only the chain's own joints are computed)."""
    B = len(q)
    R = np.repeat(np.eye(3)[None], B, axis=0)
    r = np.zeros((B, 3))
    axes, centres, dofs = [], [], []
    for joint, off in zip(joints, offsets):
        centre = R @ joint.origin_in_parent + r
        axes.append(R @ joint.axis_in_parent)
        R = R @ axis_angle_to_matrix(joint.axis_in_parent, q[:, off]) @ joint.R_parent_child_zero
        centres.append(centre)
        dofs.append(off)
        if joint.kind == "universal":
            axes.append(R @ joint.axis_in_child)
            R = R @ axis_angle_to_matrix(joint.axis_in_child, q[:, off + 1])
            centres.append(centre)
            dofs.append(off + 1)
        r = centre - R @ joint.origin_in_child
    p = R @ point + r
    J = np.zeros((B, 3, n))
    W = np.zeros((B, 3, n))
    for axis, centre, dof in zip(axes, centres, dofs):
        J[:, :, dof] = np.cross(axis, p - centre)
        W[:, :, dof] = axis
    return p, J, R, W


def _branch_and_bound(problem: _Problem, difference, tol_mm: float, max_boxes: int, batch: int = 256,
                      deadline: float | None = None) -> SpanBound:  # fmt: skip
    if problem.sources.size == 0:
        d = float(np.linalg.norm(difference(np.zeros((1, 0)))[0][0]))
        return SpanBound(d * (1 + _ROUNDING) + _ROUNDING, d, 1)
    lo, hi = problem.lower[None].copy(), problem.upper[None].copy()
    best, heap, boxes, counter = 0.0, [], 0, 0
    while True:
        d, J = difference(0.5 * (lo + hi))
        boxes += len(lo)
        best = max(best, float(np.linalg.norm(d, axis=1).max()))
        columns = np.linalg.norm(J, axis=1)
        for ub, a, b, col in zip(_bounds(problem, d, J, 0.5 * (hi - lo)), lo, hi, columns):
            if ub > best + tol_mm:
                heapq.heappush(heap, (-ub, counter, a, b, col))
                counter += 1
        take = []
        while heap and len(take) < batch and -heap[0][0] > best + tol_mm and boxes < max_boxes:
            take.append(heapq.heappop(heap))
        if not take:
            break
        if passed(deadline):  # out of time: the open boxes' bounds still hold (looser, never invalid)
            heap.extend(take)
            heapq.heapify(heap)
            break
        lo, hi = _split(problem, *(np.array([t[i] for t in take]) for i in (2, 3, 4)))
        if boxes + len(lo) > max_boxes:  # out of budget: these boxes still count
            heap.extend(take)
            heapq.heapify(heap)
            break
    upper_mm = max([best + tol_mm] + [-h[0] for h in heap])  # open boxes when the budget ran out
    return SpanBound(upper_mm * (1 + _ROUNDING) + _ROUNDING, best, boxes)


def _bounds(problem: _Problem, d: np.ndarray, J: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Upper bounds of ``|p_a - p_b|`` over boxes (see the module docstring)."""
    dot = np.abs(np.einsum("bi,bik->bk", d, J))
    first = np.einsum("bk,bk->b", np.linalg.norm(J, axis=1), half)
    linear = np.sqrt(np.einsum("bi,bi->b", d, d) + 2 * np.einsum("bk,bk->b", dot, half) + first**2)
    second = 0.5 * np.einsum("bk,kl,bl->b", half, problem.curvature_mm, half)
    lipschitz = np.linalg.norm(d, axis=1) + half @ problem.weights_mm
    return np.minimum(linear + second, lipschitz)


def _split(problem: _Problem, lo: np.ndarray, hi: np.ndarray, column_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both halves of every box, through the angle with the largest share of its bound:
    ``(|J_k| + 1/2 sum_l M_kl h_l) (hi_k - lo_k)`` (first and second order)."""
    half = 0.5 * (hi - lo)
    score = (np.maximum(column_mm, 1e-3 * problem.weights_mm) + 0.5 * half @ problem.curvature_mm) * (hi - lo)
    k = np.argmax(score, axis=1)
    rows = np.arange(len(lo))
    mid = 0.5 * (lo[rows, k] + hi[rows, k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[rows, k] = mid
    right_lo[rows, k] = mid
    return np.concatenate([lo, right_lo]), np.concatenate([left_hi, hi])


# -- a cache: tasks of one hand ask for the same spans again and again ------------------------
_CACHE: dict = {}
_CACHE_SIZE = 4096


def _fingerprint(hand: Hand) -> str:
    """A digest of everything in the hand that moves points: joints, limits, couplings."""
    h = hashlib.sha256()
    for j in hand.joints:
        h.update(f"{j.name}|{j.kind}|{j.parent}|{j.child}|{j.lower}|{j.upper}".encode())
        for a in (j.origin_in_parent, j.origin_in_child, j.axis_in_parent, j.R_parent_child_zero, j.axis_in_child):
            h.update(b"-" if a is None else np.ascontiguousarray(a, dtype=float).tobytes())
    for c in hand.couplings:
        h.update(f"{c.dof}|{c.source}|{c.ratio!r}|{c.offset!r}".encode())
    return h.hexdigest()


def span_bound_mm(hand: Hand, link_a: str, point_a_mm, link_b: str | None = None, point_b_mm=None,
                  *, tol_mm: float = 1.0, max_boxes: int = 60_000) -> float:  # fmt: skip
    """:attr:`SpanBound.upper_mm` of :func:`max_point_distance`, remembered per hand and points.

    The search stops at the :func:`~prehension.deadline.current_deadline` (the complete
    solver's time limit): the looser bound it then returns is not remembered, so a later
    call with more time gets the tight one."""
    pa = tuple(float(v) for v in np.asarray(point_a_mm, dtype=float))
    pb = None if point_b_mm is None else tuple(float(v) for v in np.asarray(point_b_mm, dtype=float))
    key = (_fingerprint(hand), link_a, pa, link_b, pb, float(tol_mm), int(max_boxes))
    if key in _CACHE:
        return _CACHE[key]
    deadline = current_deadline()
    upper = max_point_distance(hand, link_a, pa, link_b, pb, tol_mm=tol_mm, max_boxes=max_boxes, deadline=deadline).upper_mm
    if not passed(deadline):
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.clear()
        _CACHE[key] = upper
    return upper
