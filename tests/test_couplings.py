"""Couplings of any ratio in the complete solver (issue 13, item 4).

Exact multiple-angle equations for simple rational ratios, and the angle-coupling
relaxation (interval contraction and chord cuts) for every ratio: known solutions are
never lost, tasks are solved or certified, and ``solve(method="auto")`` never raises.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import random_angles
from fk_tasks import build_fk_case
from prehension.hands.model import Coupling
from prehension.results import Status
from prehension.solve import SolveOptions, solve
from prehension.solvers.complete.couplings import angle_hull, contract_couplings, cos_sin_ranges, coupling_rows
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.system import build_system, embed
from prehension.system.builder import Builder
from prehension.system.canonical import AngleCoupling
from prehension.system.couplings import exact_ratio, multiple_angle
from prehension.verification.residuals import Tolerances, evaluate
from prehension.solvers.local.verifier import LocalVerifier
from tiny_tasks import pincer_task

ANY_COLLISION = Tolerances(penetration_mm=float("inf"))


def test_exact_ratios_are_small_fractions_only():
    assert exact_ratio(1.0) == (1, 1) and exact_ratio(-1.0) == (-1, 1)
    assert exact_ratio(2.0) == (2, 1) and exact_ratio(0.5) == (1, 2) and exact_ratio(1 / 3) == (1, 3)
    assert exact_ratio(-2.5) == (-5, 2) and exact_ratio(0.0) == (0, 1)
    assert exact_ratio(0.7311) is None  # no small fraction: relaxation only
    assert exact_ratio(0.333) is None  # 0.333 is not 1/3: using 1/3 would lose solutions
    assert exact_ratio(25.0) is None  # too many multiple-angle terms


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 12])
def test_multiple_angle_polynomials_are_cos_and_sin_of_n_theta(n):
    for theta in np.random.default_rng(n).uniform(-4, 4, 5):
        b = Builder()
        c, s = b.var("c", -1, 1), b.var("s", -1, 1)
        C, S = multiple_angle(b, c, s, n, "t")
        x = b.complete_point({c: math.cos(theta), s: math.sin(theta)})
        assert C.value(x) == pytest.approx(math.cos(n * theta), abs=1e-12)
        assert S.value(x) == pytest.approx(math.sin(n * theta), abs=1e-12)


def _coupled_hand(hand, ratio: float, offset_deg: float = 0.0):
    """The SA hand with index_dip = ratio * index_pip + offset (other couplings as they are)."""
    couplings = tuple(
        Coupling(c.dof, c.source, ratio, math.radians(offset_deg)) if c.dof == "index_dip" else c for c in hand.couplings
    )
    return replace(hand, couplings=couplings)


def _angles_within_limits(hand, rng) -> np.ndarray:
    """Random angles that satisfy the couplings and every limit (rejection)."""
    while True:
        q = random_angles(hand, rng, 1)[0]
        if np.all(q >= hand.lower) and np.all(q <= hand.upper):
            return q


RATIOS = [(2.0, 0.0), (0.5, 0.0), (1 / 3, 10.0), (-0.5, 60.0), (0.7311, 0.0), (1.37, -5.0)]


@pytest.mark.parametrize("ratio,offset", RATIOS)
def test_known_solutions_of_coupled_hands_are_points_of_the_system(sa_hand, ratio, offset):
    hand = _coupled_hand(sa_hand, ratio, offset)
    for seed in range(3):
        rng = np.random.default_rng(50 + seed)
        case = build_fk_case(hand, rng, fingers=("thumb", "index"), q=_angles_within_limits(hand, rng))
        assert evaluate(case.task, case.config, ANY_COLLISION).ok
        form = build_system(case.task)
        x = embed(form, case.config)
        system = form.system
        assert len(system.couplings) == 2  # index and thumb dip
        assert np.abs(system.residuals(x)).max() < 1e-9
        assert system.inequality_violation(x) < 1e-9 and system.coupling_violation(x) < 1e-9
        lo, hi = x.copy(), x.copy()
        assert not contract_couplings(system.couplings, lo, hi)  # the point itself is kept


@pytest.mark.parametrize("ratio,offset", RATIOS)
def test_a_wrong_angle_breaks_the_coupling(sa_hand, ratio, offset):
    hand = _coupled_hand(sa_hand, ratio, offset)
    rng = np.random.default_rng(9)
    q = _angles_within_limits(hand, rng)
    q_bad = q.copy()
    q_bad[hand.dof_index("index_dip")] += 0.02  # 1.1 deg off the coupling, still within limits
    bad = build_fk_case(hand, np.random.default_rng(9), fingers=("thumb", "index"), q=q_bad)
    form = build_system(bad.task)
    x = embed(form, bad.config)
    assert form.system.coupling_violation(x) == pytest.approx(0.02, abs=1e-9)
    assert contract_couplings(form.system.couplings, x.copy(), x.copy())  # a point box: proven empty


# -- the relaxation contains what it bounds ---------------------------------------------------
def _random_range(rng):
    lo = rng.uniform(-4, 2)
    return lo, lo + rng.choice([rng.uniform(0.05, 1.0), rng.uniform(1.0, 6.0), rng.uniform(6.3, 14.0)])


def test_angle_hull_contains_every_angle_of_the_box(rng):
    for _ in range(3000):
        lo, hi = _random_range(rng)
        theta = rng.uniform(lo, hi)
        c, s = math.cos(theta), math.sin(theta)
        w = rng.choice([1e-12, 1e-6, 1e-3, 0.1, 1.0])
        box = (c - rng.uniform(0, w), c + rng.uniform(0, w), s - rng.uniform(0, w), s + rng.uniform(0, w))
        hull = angle_hull(lo, hi, *box)
        assert hull is not None and hull[0] <= theta <= hull[1]
        assert lo <= hull[0] and hull[1] <= hi


def test_angle_hull_is_empty_only_when_no_angle_fits(rng):
    assert angle_hull(0.0, 1.0, -1.0, -0.9, -0.1, 0.1) is None  # cos near -1: angle near pi, outside
    assert angle_hull(0.0, 1.0, 0.1, 0.2, 0.1, 0.2) is None  # inside the unit disc, off the circle
    assert angle_hull(-10.0, 10.0, 0.1, 0.2, 0.97, 1.0) is not None
    for _ in range(2000):  # a box that misses every angle of the range is reported empty or keeps them
        lo, hi = _random_range(rng)
        box = np.sort(rng.uniform(-1.1, 1.1, 2)).tolist() + np.sort(rng.uniform(-1.1, 1.1, 2)).tolist()
        hull = angle_hull(lo, hi, *box)
        t = np.linspace(lo, hi, 2001)
        inside = (np.cos(t) >= box[0]) & (np.cos(t) <= box[1]) & (np.sin(t) >= box[2]) & (np.sin(t) <= box[3])
        if inside.any():
            assert hull is not None and hull[0] <= t[inside].min() and t[inside].max() <= hull[1]


def test_cos_sin_ranges_contain_the_arc(rng):
    for _ in range(2000):
        a = rng.uniform(-10, 10)
        b = a + rng.choice([rng.uniform(0, 1e-6), rng.uniform(0, 2.0), rng.uniform(2.0, 7.0)])
        cl, cu, sl, su = cos_sin_ranges(a, b)
        t = np.concatenate([[a, b], rng.uniform(a, b, 200)])
        assert np.all(np.cos(t) >= cl) and np.all(np.cos(t) <= cu)
        assert np.all(np.sin(t) >= sl) and np.all(np.sin(t) <= su)


def test_contraction_and_chord_cuts_never_lose_a_coupled_point(rng):
    n_cuts = 0
    for _ in range(1500):
        ratio = rng.choice([2.0, 0.5, -1 / 3, 0.7311, -1.37, 1.0, 0.0])
        offset = rng.uniform(-1, 1)
        range_s = _random_range(rng)
        ts = rng.uniform(*range_s)
        td = ratio * ts + offset
        range_d = (td - rng.uniform(0, 3), td + rng.uniform(0, 3))
        c = AngleCoupling(0, 1, 2, 3, ratio, offset, range_d, range_s)
        x = np.array([math.cos(td), math.sin(td), math.cos(ts), math.sin(ts)])
        w = rng.choice([1e-9, 1e-4, 0.05, 0.5, 2.0], size=4)
        lower, upper = x - rng.uniform(0, 1, 4) * w, x + rng.uniform(0, 1, 4) * w
        rows = coupling_rows([c], lower, upper)
        assert not contract_couplings([c], lower, upper)
        assert np.all(lower <= x) and np.all(x <= upper)
        if rows is not None:
            cols, coef, rhs = rows
            n_cuts += len(cols)
            assert np.all(np.einsum("brc,bc->br", coef, x[cols]) <= rhs)
    assert n_cuts > 500  # the cuts were exercised


# -- the solver on coupled hands ---------------------------------------------------------------
def _coupled_pincer(ratio: float, d: float):
    task = pincer_task(d)
    return replace(task, hand=replace(task.hand, couplings=(Coupling("j2", "j1", ratio),)))


def _coupled_pincer_reach(ratio: float) -> float:
    """The one distance d at which the pincer with j2 = ratio j1 reaches both points: the
    fingertip centre must be at height 100 mm (see tiny_tasks.py), which fixes j1."""
    j1 = brentq(lambda j: 40 * np.cos(j) + 30 * np.cos((1 + ratio) * j) - 50, 0.0, np.pi / 2)
    return 40 * np.sin(j1) + 30 * np.sin((1 + ratio) * j1) - 2.0


@pytest.mark.parametrize("ratio", [2.0, 0.5, 0.7311])
def test_coupled_pincer_is_solved_at_its_reach_and_certified_past_it(ratio):
    d = _coupled_pincer_reach(ratio)
    solved = solve_complete(_coupled_pincer(ratio, d), BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert solved.status == Status.SOLVED and solved.solutions[0].report.ok
    j1, j2 = solved.solutions[0].q
    assert j2 == pytest.approx(ratio * j1, abs=1e-9)
    if ratio != 0.5:
        return
    past = solve_complete(_coupled_pincer(ratio, d + 3.0), BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert past.status == Status.INFEASIBLE and not past.solutions


def test_auto_solve_on_a_coupled_hand_never_raises():
    """Issue 13: auto used to crash with InvalidTask on a ratio other than +-1."""
    result = solve(_coupled_pincer(0.7311, _coupled_pincer_reach(0.7311) + 3.0),
                   SolveOptions(complete_options=BranchAndPruneOptions(time_limit_s=60)))  # fmt: skip
    assert result.status == Status.INFEASIBLE and "complete solver" in result.message


@pytest.mark.parametrize("ratio,offset", [(2.0, 0.0), (1 / 3, 10.0)])
def test_fk_tasks_on_coupled_sa_hands_are_solved(sa_hand, ratio, offset):
    hand = _coupled_hand(sa_hand, ratio, offset)
    rng = np.random.default_rng(77)
    case = build_fk_case(hand, rng, fingers=("thumb", "index"), q=_angles_within_limits(hand, rng), palm=False)
    result = solve_complete(case.task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=120, tolerances=ANY_COLLISION))
    assert result.status == Status.SOLVED
    q = result.solutions[0].q
    assert q[hand.dof_index("index_dip")] == pytest.approx(ratio * q[hand.dof_index("index_pip")] + math.radians(offset), abs=1e-9)
