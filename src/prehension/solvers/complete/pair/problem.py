"""The pair test's problem: the variables and constants of two contacts, and its boxes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ....hands.reach import PairKinematics, pair_kinematics
from ....tasks.model import Task
from ..region_kinds import hand_tip, region_curvature

__all__ = ["REL_PAD", "PairProblem", "PairOutcome", "pair_problem", "halves", "halves_widest"]

#: Relative margin for floating-point rounding on every comparison of the pair test (as in
#: :mod:`prehension.hands.reach`).
REL_PAD = 1e-9


# -- one pair -----------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PairProblem:
    """The variables and constants of the pair test of contacts ``a`` and ``b``.

    The box dimensions are, in order: the pair's joint angles (sources), the parameters
    of object region ``a`` and of object region ``b``.
    """

    contacts: tuple[int, int]
    kin: PairKinematics
    hand: tuple  # per side: (region, radius [mm]) of the hand region
    objects: tuple  # per side: (region, (M_point, M_normal))
    slices: tuple  # angles, object a, object b
    lower: np.ndarray
    upper: np.ndarray
    points: tuple = ()  # per side: (link, fingertip centre or hand point in the link [mm])
    tips: tuple = ()  # per side: the hand region as a :class:`~..region_kinds.HandTip`

    @property
    def n_dims(self) -> int:
        return len(self.lower)

    @property
    def betas(self) -> tuple[float, float]:
        """Per side, the cap's half angle [rad] (0 for a hand point: a fixed normal)."""
        return tuple(tip.half_angle for tip in self.tips)

    @property
    def caps(self) -> tuple[bool, bool]:
        """Per side, whether the hand region is a cap (its normal within ``beta`` of its axis)."""
        return tuple(tip.cone for tip in self.tips)


def pair_problem(task: Task, a: int, b: int) -> PairProblem | None:
    """The pair test's problem, or None when a region kind is not supported (hand patches)."""
    hands, objects, centres, tips = [], [], [], []
    for i in (a, b):
        hreg, oreg = task.hand_region(task.contacts[i]), task.object_region(task.contacts[i])
        tip, curvature = hand_tip(hreg.region), region_curvature(oreg)
        if tip is None or curvature is None:
            return None
        centres.append((hreg.link, tip.centre))
        hands.append((hreg, tip.radius))
        objects.append((oreg, curvature))
        tips.append(tip)
    kin = pair_kinematics(task.hand, centres[0][0], centres[0][1], centres[1][0], centres[1][1])
    lo, hi = _angle_bounds(task, kin)
    bounds = [(lo, hi)] + [o[0].param_bounds() for o in objects]
    edges = np.cumsum([0] + [len(np.atleast_1d(x[0])) for x in bounds])
    slices = tuple(slice(int(s), int(e)) for s, e in zip(edges[:-1], edges[1:]))
    lower = np.concatenate([np.asarray(x[0], dtype=float) for x in bounds])
    upper = np.concatenate([np.asarray(x[1], dtype=float) for x in bounds])
    return PairProblem((a, b), kin, tuple(hands), tuple(objects), slices, lower, upper, tuple(centres), tuple(tips))


def _angle_bounds(task: Task, kin: PairKinematics) -> tuple[np.ndarray, np.ndarray]:
    """The sources' limits, narrowed by the limits of the dofs they drive."""
    hand, problem = task.hand, kin.problem
    lo, hi = problem.lower.astype(float).copy(), problem.upper.astype(float).copy()
    for dof, pos, ratio, offset in problem.driven:
        if ratio != 0.0:
            ends = sorted(((hand.lower[dof] - offset) / ratio, (hand.upper[dof] - offset) / ratio))
            lo[pos], hi[pos] = max(lo[pos], ends[0] - 1e-12), min(hi[pos], ends[1] + 1e-12)
    return lo, hi


# -- branch and prune ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class PairOutcome:
    """Result of the pair tests (:func:`.product.prove_pair_infeasible`, ...).

    Attributes:
        proved: every box was discarded: the two contacts cannot be made together.
        boxes: boxes evaluated.
        seconds: time spent.
        stopped: why the search stopped without a proof ("" when proved): a witness box
            (the pair can be made), or a budget.
        witness: the centre of the surviving narrow box (box dimensions), or None.
    """

    proved: bool
    boxes: int
    seconds: float
    stopped: str = ""
    witness: np.ndarray | None = None


# -- splitting boxes ----------------------------------------------------------------------------------
def halves(lo: np.ndarray, hi: np.ndarray, score: np.ndarray, scale: np.ndarray):
    """Both halves of every box, through the dimension with the largest score (widest, when
    every score is 0)."""
    if not len(lo):
        return lo, hi
    rel = (hi - lo) / scale
    k = np.argmax(np.where(rel > 1e-12, score + 1e-9 * rel, -1.0), axis=1)
    rows = np.arange(len(lo))
    mid = 0.5 * (lo[rows, k] + hi[rows, k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[rows, k], right_lo[rows, k] = mid, mid
    return np.concatenate([right_lo, lo]), np.concatenate([hi, left_hi])


def halves_widest(lo: np.ndarray, hi: np.ndarray, dims: np.ndarray, scale: np.ndarray):
    """Both halves of every box through its widest relative dimension among ``dims``."""
    k = dims[np.argmax(((hi - lo) / scale)[:, dims], axis=1)]
    rows = np.arange(len(lo))
    mid = 0.5 * (lo[rows, k] + hi[rows, k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[rows, k], right_lo[rows, k] = mid, mid
    return np.concatenate([lo, right_lo]), np.concatenate([left_hi, hi])
