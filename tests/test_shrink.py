"""Interval contraction and LP box shrinking: never lose a solution, shrink, detect emptiness.

The random systems have an *exactly* representable solution ``x*`` (dyadic values, small
integer matrices), so "``x*`` is still in the box" is checked without any tolerance.
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from math import comb

import highspy
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import linprog

from prehension.solvers.complete import shrink as shrink_mod
from prehension.solvers.complete.contract import contract, contract_linear
from prehension.solvers.complete.shrink import (
    ShrinkOptions,
    farkas_infeasible,
    safe_lower_bound,
    shrink_box,
)
from prehension.system.canonical import BernsteinEquation, System


def make_system(names, lower, upper, A=None, b=(), G=None, h=(), squares=(), products=(), bernstein=()):
    n = len(names)
    return System(
        names=tuple(names),
        lower=np.asarray(lower, dtype=float),
        upper=np.asarray(upper, dtype=float),
        A=sp.csr_matrix(np.asarray(A, dtype=float).reshape(-1, n)) if A is not None else sp.csr_matrix((0, n)),
        b=np.asarray(b, dtype=float),
        G=sp.csr_matrix(np.asarray(G, dtype=float).reshape(-1, n)) if G is not None else sp.csr_matrix((0, n)),
        h=np.asarray(h, dtype=float),
        squares=np.asarray(squares, dtype=int).reshape(-1, 2),
        products=np.asarray(products, dtype=int).reshape(-1, 3),
        bernstein=tuple(bernstein),
    )


def exact_bernstein(coeffs, s: Fraction, t: Fraction) -> Fraction:
    dp, dq = coeffs.shape[0] - 1, coeffs.shape[1] - 1
    bs = [comb(dp, p) * s**p * (1 - s) ** (dp - p) for p in range(dp + 1)]
    bt = [comb(dq, q) * t**q * (1 - t) ** (dq - q) for q in range(dq + 1)]
    return sum(bs[p] * bt[q] * Fraction(float(coeffs[p, q])) for p in range(dp + 1) for q in range(dq + 1))


def exact_float(value: Fraction) -> float:
    out = float(value)
    assert Fraction(out) == value, "test data must be exactly representable"
    return out


def random_system(rng):
    """A random system and an exactly representable solution of it."""
    nb = int(rng.integers(2, 5))
    base = [Fraction(int(k), 16) for k in rng.integers(-16, 17, size=nb)]
    uv = [Fraction(int(k), 16) for k in rng.integers(0, 17, size=2)]
    values = base + uv
    lower, upper = [-1.0] * nb + [0.0, 0.0], [1.0] * nb + [1.0, 1.0]
    squares, products, bernstein = [], [], []
    for i in rng.choice(nb, size=int(rng.integers(1, nb + 1)), replace=False):
        squares.append((len(values), int(i)))
        values.append(values[i] ** 2)
        lower.append(0.0), upper.append(1.0)
    for _ in range(int(rng.integers(1, 3))):
        i, j = rng.choice(nb + 2, size=2, replace=False)
        products.append((len(values), int(i), int(j)))
        values.append(values[i] * values[j])
        lower.append(-1.0), upper.append(1.0)
    for _ in range(int(rng.integers(0, 3))):
        dp, dq = rng.integers(0, 4, size=2)
        coeffs = rng.integers(-16, 17, size=(dp + 1, dq + 1)) / 16.0
        bernstein.append(BernsteinEquation(k=len(values), i=nb, j=nb + 1, coeffs=coeffs))
        values.append(exact_bernstein(coeffs, uv[0], uv[1]))
        lower.append(-1.0), upper.append(1.0)
    n = len(values)
    A = rng.integers(-2, 3, size=(int(rng.integers(1, max(2, n // 2))), n)) * (rng.uniform(size=(1, n)) < 0.7)
    b = [exact_float(sum(int(a) * v for a, v in zip(row, values))) for row in A]
    G = rng.integers(-2, 3, size=(int(rng.integers(0, 3)), n))
    h = [exact_float(sum(int(a) * v for a, v in zip(row, values)) + Fraction(int(rng.integers(0, 2)), 4)) for row in G]
    x_star = np.array([exact_float(v) for v in values])
    names = [f"x{i}" for i in range(n)]
    system = make_system(names, lower, upper, A, b, G, h, squares, products, bernstein)
    return system, x_star


def random_box_around(rng, system, x_star):
    """A sub-box of the system's box containing ``x_star``: thin, wide, or touching it."""
    widths = np.array([0.0, 1e-12, 1e-7, 1e-3, 0.1, 1.0])
    below = rng.choice(widths, size=len(x_star)) * rng.uniform(size=len(x_star))
    above = rng.choice(widths, size=len(x_star)) * rng.uniform(size=len(x_star))
    lower = np.maximum(system.lower, x_star - below)
    upper = np.minimum(system.upper, x_star + above)
    assert np.all(lower <= x_star) and np.all(x_star <= upper)
    return lower, upper


def inside(lower, upper, x) -> bool:
    return bool(np.all(lower <= x) and np.all(x <= upper))


# ----------------------------------------------------------------------------------
# Never discard a solution
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(40))
def test_contraction_and_shrinking_keep_the_solution(seed):
    rng = np.random.default_rng(1000 + seed)
    system, x_star = random_system(rng)
    assert np.max(np.abs(system.residuals(x_star))) < 1e-12
    for _ in range(3):
        lower, upper = random_box_around(rng, system, x_star)
        lo, hi, empty = contract(system, lower, upper)
        assert not empty and inside(lo, hi, x_star)
        assert np.all(lo >= lower) and np.all(hi <= upper)
        res = shrink_box(system, lower, upper, ShrinkOptions(max_passes=4))
        assert not res.empty and inside(res.lower, res.upper, x_star), (seed, res.reason)
        assert np.all(res.lower >= lower) and np.all(res.upper <= upper)
        res = shrink_box(system, lower, upper, ShrinkOptions(max_passes=2, contract=False, midpoint_tangent=False))
        assert not res.empty and inside(res.lower, res.upper, x_star)


#: the cheaper passes: a feasibility LP first, narrowest first, passes stopped early
CHEAP = (ShrinkOptions(max_passes=4, feasibility_first=True),
         ShrinkOptions(max_passes=4, lp_order="narrowest", stop_after=1, stop_gain=0.5),
         ShrinkOptions(max_passes=3, feasibility_first=True, lp_order="narrowest", stop_after=2),
         ShrinkOptions(max_passes=2, contract=False, feasibility_first=True, stop_after=1, stop_gain=1.0))


@pytest.mark.parametrize("seed", range(40))
def test_cheaper_passes_keep_the_solution(seed):
    """A pass that starts with a feasibility LP, bounds the narrowest first or stops early
    never loses a solution (and never widens the box)."""
    rng = np.random.default_rng(5000 + seed)
    system, x_star = random_system(rng)
    for options in CHEAP:
        lower, upper = random_box_around(rng, system, x_star)
        res = shrink_box(system, lower, upper, options)
        assert not res.empty and inside(res.lower, res.upper, x_star), (seed, options, res.reason)
        assert np.all(res.lower >= lower) and np.all(res.upper <= upper)


@pytest.mark.parametrize("seed", range(5))
def test_solution_on_the_box_boundary_survives_repeated_shrinking(seed):
    rng = np.random.default_rng(2000 + seed)
    system, x_star = random_system(rng)
    lower = np.maximum(system.lower, x_star - 0.25)
    upper = x_star.copy()  # x* is the upper corner of the box
    for _ in range(3):
        res = shrink_box(system, lower, upper, ShrinkOptions(rho=0.99, max_passes=20))
        assert not res.empty and inside(res.lower, res.upper, x_star)
        lower, upper = res.lower, res.upper


# ----------------------------------------------------------------------------------
# Shrinking converges on isolated solutions
# ----------------------------------------------------------------------------------
def circle_line():
    """x^2 + y^2 = 1, x = y on [0, 1]^2 via X = x^2, Y = y^2: the point (1/sqrt2, 1/sqrt2)."""
    return make_system("x y X Y".split(), [0, 0, 0, 0], [1, 1, 1, 1], A=[[0, 0, 1, 1], [1, -1, 0, 0]], b=[1, 0],
                       squares=[(2, 0), (3, 1)])


@pytest.mark.parametrize("contract_first", [True, False])
def test_shrinking_converges_to_the_point(contract_first):
    system = circle_line()
    options = ShrinkOptions(rho=0.99, max_passes=50, contract=contract_first)
    res = shrink_box(system, system.lower, system.upper, options)
    assert not res.empty and res.n_lps > 0 and res.n_failed_lps == 0
    assert np.all(res.upper - res.lower < 1e-9)
    half = Fraction(1, 2)
    for i in (0, 1):  # exact: lower^2 <= 1/2 <= upper^2
        assert Fraction(res.lower[i]) ** 2 <= half <= Fraction(res.upper[i]) ** 2
    for i in (2, 3):
        assert res.lower[i] <= 0.5 <= res.upper[i]


def test_shrinking_converges_with_a_bernstein_equation():
    """u^2 + v^2 = 1/2 (in Bernstein form), u = v: the point (1/2, 1/2)."""
    a = np.array([0.0, 0.0, 1.0])  # Bernstein coefficients of t^2, degree 2
    coeffs = np.add.outer(a, a)
    system = make_system("u v F".split(), [0, 0, -1], [1, 1, 3], A=[[0, 0, 1], [1, -1, 0]], b=[0.5, 0],
                         bernstein=[BernsteinEquation(k=2, i=0, j=1, coeffs=coeffs)])
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(rho=0.99, max_passes=60))
    assert not res.empty
    assert inside(res.lower, res.upper, np.array([0.5, 0.5, 0.5]))
    assert np.all(res.upper - res.lower < 1e-6)


def test_rho_and_max_passes_limit_the_work():
    system = circle_line()
    one = shrink_box(system, system.lower, system.upper, ShrinkOptions(max_passes=1))
    many = shrink_box(system, system.lower, system.upper, ShrinkOptions(rho=0.99, max_passes=50))
    assert one.n_passes == 1 and many.n_passes > 1 and many.n_lps > one.n_lps
    assert np.all(many.upper - many.lower <= one.upper - one.lower)
    subset = shrink_box(system, system.lower, system.upper, ShrinkOptions(max_passes=1, variables=(0,), contract=False))
    assert subset.n_lps == 2
    assert subset.lower[1] == 0.0 and subset.upper[1] == 1.0  # not LP-shrunk
    assert subset.lower[0] > 0.4


def test_a_pass_stops_after_dull_lps():
    """``stop_after``: a pass ends once that many LPs in a row narrowed less than
    ``stop_gain`` of their variable's width (a gain of 1 is never reached: every LP is dull)."""
    system = circle_line()
    full = shrink_box(system, system.lower, system.upper, ShrinkOptions(max_passes=1, contract=False))
    for k in (1, 3):
        short = shrink_box(system, system.lower, system.upper,
                           ShrinkOptions(max_passes=1, contract=False, stop_after=k, stop_gain=1.0))
        assert short.n_lps == k < full.n_lps
        assert np.all(short.upper - short.lower >= full.upper - full.lower)
    keen = shrink_box(system, system.lower, system.upper, ShrinkOptions(max_passes=1, contract=False, stop_after=1,
                                                                        stop_gain=0.0))  # fmt: skip
    assert keen.n_lps == full.n_lps  # no LP narrows by less than nothing


def test_narrowest_first_order():
    system = circle_line()
    lower, upper = system.lower.copy(), system.upper.copy()
    upper[3] = 0.6  # Y the narrowest, then x, y, X in index order (stable)
    thin = np.zeros(4, dtype=bool)
    options = ShrinkOptions(lp_order="narrowest")
    assert shrink_mod._pass_order(system, lower, upper, options, thin).tolist() == [3, 0, 1, 2]
    thin[0] = True
    assert shrink_mod._pass_order(system, lower, upper, options, thin).tolist() == [3, 1, 2]


# ----------------------------------------------------------------------------------
# Emptiness
# ----------------------------------------------------------------------------------
def test_feasibility_lp_proves_emptiness_alone():
    """The feasibility LP empties a box with a verified Farkas certificate, at one LP."""
    system = make_system(["x", "y"], [0, 0], [1, 1], A=[[1, 1], [1, 1]], b=[0.5, 0.75])
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=False, feasibility_first=True))
    assert res.empty and res.reason == "farkas" and res.n_lps == 1


def test_square_with_negative_box_is_empty():
    system = make_system(["x", "y"], [-1, -2], [1, -1], squares=[(1, 0)])
    assert contract(system, system.lower, system.upper).empty
    res = shrink_box(system, system.lower, system.upper)
    assert res.empty and res.reason == "contraction"


@pytest.mark.parametrize("contract_first", [True, False])
def test_parallel_equations_are_empty(contract_first):
    system = make_system(["x", "y"], [0, 0], [1, 1], A=[[1, 1], [1, 1]], b=[0.5, 0.75])
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=contract_first))
    assert res.empty
    assert res.reason == ("contraction" if contract_first else "farkas")


@pytest.mark.parametrize("contract_first", [True, False])
def test_box_far_from_the_circle_is_empty(contract_first):
    system = make_system("x y X Y".split(), [2, 2, 0, 0], [3, 3, 10, 10], A=[[0, 0, 1, 1]], b=[1],
                         squares=[(2, 0), (3, 1)])
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=contract_first))
    assert res.empty
    assert res.reason in (("contraction",) if contract_first else ("farkas", "lp-bound"))


def test_box_near_the_circle_is_not_empty():
    system = make_system("x y X Y".split(), [0, 0, 0, 0], [1, 1, 1, 1], A=[[0, 0, 1, 1]], b=[1],
                         squares=[(2, 0), (3, 1)])
    lower = np.array([1.0, 0.0, 0.0, 0.0])  # touches the circle at (1, 0) only
    res = shrink_box(system, lower, system.upper, ShrinkOptions(rho=0.99, max_passes=30))
    assert not res.empty and inside(res.lower, res.upper, np.array([1.0, 0.0, 1.0, 0.0]))


def test_inverted_box_is_empty():
    system = circle_line()
    res = shrink_box(system, np.array([0.5, 0, 0, 0]), np.array([0.4, 1, 1, 1]))
    assert res.empty and res.reason == "input" and res.n_lps == 0


# ----------------------------------------------------------------------------------
# Solver failures never mean "empty"
# ----------------------------------------------------------------------------------
def test_lp_error_status_means_no_reduction(monkeypatch):
    class BrokenHighs(highspy.Highs):
        def getModelStatus(self):
            return highspy.HighsModelStatus.kSolveError

    monkeypatch.setattr(shrink_mod.highspy, "Highs", BrokenHighs)
    system = circle_line()
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=False))
    assert not res.empty and res.n_lps == 8 and res.n_failed_lps == 8
    assert np.array_equal(res.lower, system.lower) and np.array_equal(res.upper, system.upper)


def test_lp_exception_means_no_reduction(monkeypatch):
    class RaisingHighs(highspy.Highs):
        def run(self):
            raise RuntimeError("solver crashed")

    monkeypatch.setattr(shrink_mod.highspy, "Highs", RaisingHighs)
    system = circle_line()
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=False))
    assert not res.empty and res.n_failed_lps == res.n_lps == 8
    assert np.array_equal(res.lower, system.lower)


@pytest.mark.parametrize("feasibility_first", [False, True])
def test_unverified_infeasibility_is_not_empty(monkeypatch, feasibility_first):
    """HiGHS saying "infeasible" with a ray that proves nothing: no reduction, not empty, and
    the pass stops there (with ``feasibility_first``, at its feasibility LP)."""
    class LyingHighs(highspy.Highs):
        def getModelStatus(self):
            return highspy.HighsModelStatus.kInfeasible

        def getDualRay(self):
            return highspy.HighsStatus.kOk, True, np.ones(self.getNumRow())

    monkeypatch.setattr(shrink_mod.highspy, "Highs", LyingHighs)
    system = circle_line()
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(contract=False, feasibility_first=feasibility_first))
    assert not res.empty and res.unverified_infeasible and res.n_lps == 1
    assert np.array_equal(res.lower, system.lower) and np.array_equal(res.upper, system.upper)


@pytest.mark.parametrize("seed", range(5))
def test_garbage_duals_never_cut_the_solution(monkeypatch, seed):
    rng = np.random.default_rng(3000 + seed)

    class Garbage:
        def __init__(self, m):
            self.row_dual = rng.normal(size=m) * rng.choice([1e-3, 1.0, 1e6])

    class GarbageHighs(highspy.Highs):
        def getSolution(self):
            return Garbage(self.getNumRow())

    monkeypatch.setattr(shrink_mod.highspy, "Highs", GarbageHighs)
    system, x_star = random_system(rng)
    lower, upper = random_box_around(rng, system, x_star)
    res = shrink_box(system, lower, upper, ShrinkOptions(contract=False, max_passes=2))
    assert not res.empty and inside(res.lower, res.upper, x_star)


# ----------------------------------------------------------------------------------
# Safe (Neumaier-Shcherbina) bounds
# ----------------------------------------------------------------------------------
def ns_exact(M, row_lo, row_hi, c, lower, upper, y) -> Fraction:
    """The Neumaier-Shcherbina bound in exact arithmetic (same sign clipping)."""
    M = np.asarray(M, dtype=float)
    total = Fraction(0)
    yf = []
    for r, yr in enumerate(y):
        if (yr > 0 and row_lo[r] == -np.inf) or (yr < 0 and row_hi[r] == np.inf):
            yr = 0.0
        yf.append(Fraction(float(yr)))
        if yr > 0:
            total += yf[-1] * Fraction(float(row_lo[r]))
        elif yr < 0:
            total += yf[-1] * Fraction(float(row_hi[r]))
    for j in range(M.shape[1]):
        rj = Fraction(float(c[j])) - sum(Fraction(float(M[r, j])) * yf[r] for r in range(M.shape[0]))
        total += min(rj * Fraction(float(lower[j])), rj * Fraction(float(upper[j])))
    return total


def test_safe_bound_hand_example():
    # min x1 + 2 x2  s.t.  x1 + x2 >= 1,  x in [0, 2]^2:  optimum 1 at (1, 0), dual y = 1
    M = np.array([[1.0, 1.0]])
    lo, hi = np.array([1.0]), np.array([np.inf])
    c, box_lo, box_hi = np.array([1.0, 2.0]), np.zeros(2), np.full(2, 2.0)
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [1.0]) == pytest.approx(1.0, abs=1e-14)
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [1.0]) <= 1.0
    # y = 1.1: r = (-0.1, 0.9) -> 1.1 + min(-0.1 * 0, -0.1 * 2) + 0 = 0.9
    b = safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [1.1])
    exact = ns_exact(M, lo, hi, c, box_lo, box_hi, [1.1])
    assert Fraction(b) <= exact and float(exact) - b < 1e-14 and abs(float(exact) - 0.9) < 1e-15
    # y = 0.5 -> 0.5;  y = -1 has the wrong sign for an infinite upper row bound -> 0
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [0.5]) == pytest.approx(0.5, abs=1e-14)
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [-1.0]) == pytest.approx(0.0, abs=1e-300)
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [-1.0]) <= 0.0
    # NaN multipliers are ignored
    assert safe_lower_bound(M, lo, hi, c, box_lo, box_hi, [np.nan]) <= 0.0


def exact_lp_min(c, A, b, G, h, lower, upper) -> Fraction:
    """Exact LP optimum by vertex enumeration (tiny problems, rational arithmetic)."""
    n = len(c)
    rows = [(list(map(Fraction, map(float, a))), Fraction(float(v)), "eq") for a, v in zip(A, b)]
    ineq = [(list(map(Fraction, map(float, g))), Fraction(float(v))) for g, v in zip(G, h)]
    for j in range(n):
        e = [Fraction(int(k == j)) for k in range(n)]
        ineq.append((e, Fraction(float(upper[j]))))
        ineq.append(([-x for x in e], -Fraction(float(lower[j]))))
    best = None
    for active in itertools.combinations(range(len(ineq)), n - len(rows)):
        system = [r[:2] for r in rows] + [ineq[k] for k in active]
        x = solve_exact([s[0] for s in system], [s[1] for s in system])
        if x is None:
            continue
        if all(sum(a * xi for a, xi in zip(r[0], x)) == r[1] for r in rows) and all(
            sum(a * xi for a, xi in zip(g, x)) <= v for g, v in ineq
        ):
            val = sum(Fraction(float(cj)) * xj for cj, xj in zip(c, x))
            best = val if best is None else min(best, val)
    return best


def solve_exact(M, v):
    n = len(M)
    aug = [list(row) + [vi] for row, vi in zip(M, v)]
    for col in range(n):
        piv = next((r for r in range(col, n) if aug[r][col] != 0), None)
        if piv is None:
            return None
        aug[col], aug[piv] = aug[piv], aug[col]
        for r in range(n):
            if r != col and aug[r][col] != 0:
                f = aug[r][col] / aug[col][col]
                aug[r] = [x - f * y for x, y in zip(aug[r], aug[col])]
    return [aug[r][n] / aug[r][r] for r in range(n)]


@pytest.mark.parametrize("seed", range(15))
def test_safe_bound_is_below_the_exact_lp_optimum(seed):
    rng = np.random.default_rng(4000 + seed)
    n = 3
    x0 = rng.integers(-8, 9, size=n) / 8.0
    A = rng.integers(-3, 4, size=(1, n)).astype(float)
    b = A @ x0
    G = rng.integers(-3, 4, size=(2, n)).astype(float)
    h = G @ x0 + rng.integers(0, 3, size=2) / 4.0
    lower, upper = x0 - rng.integers(0, 5, size=n) / 4.0, x0 + rng.integers(0, 5, size=n) / 4.0
    c = rng.integers(-4, 5, size=n) / 2.0
    exact = exact_lp_min(c, A, b, G, h, lower, upper)
    assert exact is not None
    res = linprog(c, A_ub=G, b_ub=h, A_eq=A, b_eq=b, bounds=list(zip(lower, upper)), method="highs")
    assert res.status == 0
    M = np.vstack([A, G])
    row_lo = np.concatenate([b, [-np.inf, -np.inf]])
    row_hi = np.concatenate([b, h])
    y = np.concatenate([res.eqlin.marginals, res.ineqlin.marginals])
    bound = safe_lower_bound(M, row_lo, row_hi, c, lower, upper, y)
    assert Fraction(bound) <= exact
    assert float(exact) - bound < 1e-9  # with the optimal duals the bound is tight
    for scale in (1e-6, 1e-2, 1.0):
        y_bad = y + scale * rng.normal(size=len(y))
        bound = safe_lower_bound(M, row_lo, row_hi, c, lower, upper, y_bad)
        assert Fraction(bound) <= exact
        assert Fraction(bound) <= ns_exact(M, row_lo, row_hi, c, lower, upper, y_bad)


def test_farkas_certificate():
    M = np.array([[1.0, 1.0], [1.0, 1.0]])
    lo = hi = np.array([0.5, 0.75])
    box_lo, box_hi = np.zeros(2), np.ones(2)
    assert farkas_infeasible(M, lo, hi, box_lo, box_hi, [1.0, -1.0])
    assert farkas_infeasible(M, lo, hi, box_lo, box_hi, [-1.0, 1.0])
    assert not farkas_infeasible(M, lo, hi, box_lo, box_hi, [1.0, 1.0])
    assert not farkas_infeasible(M, lo, hi, box_lo, box_hi, [0.0, 0.0])
    # a consistent system never verifies, whatever the multipliers
    rng = np.random.default_rng(5)
    for _ in range(50):
        assert not farkas_infeasible(M, [0.5, 0.5], [0.5, 0.5], box_lo, box_hi, rng.normal(size=2))


# ----------------------------------------------------------------------------------
# Contraction details
# ----------------------------------------------------------------------------------
def test_square_backward_picks_the_right_branch():
    system = make_system(["x", "X"], [-3, 1], [0.5, 4], squares=[(1, 0)])
    lo, hi, empty = contract(system, system.lower, system.upper)
    assert not empty
    assert lo[0] <= -2 and lo[0] > -2 - 1e-12 and hi[0] >= -1 and hi[0] < -1 + 1e-12
    assert lo[1] == 1 and hi[1] == 4


def test_product_division_and_forward():
    system = make_system(["x", "y", "P"], [-10, 2, 1], [10, 4, 2], products=[(2, 0, 1)])
    lo, hi, empty = contract(system, system.lower, system.upper)
    assert not empty
    assert lo[0] <= 0.25 and lo[0] > 0.25 - 1e-12 and hi[0] >= 1 and hi[0] < 1 + 1e-12


def test_linear_contraction_is_outward_rounded():
    # x + y = 0.3 with y = 0.1 exactly (as floats): the exact x = 0.3 - 0.1 (real) must stay inside
    lower, upper = np.array([-1.0, 0.1]), np.array([1.0, 0.1])
    M = sp.csr_matrix(np.array([[1.0, 1.0]]))
    assert not contract_linear(M, np.array([0.3]), np.array([0.3]), lower, upper)
    exact = Fraction(0.3) - Fraction(0.1)
    assert Fraction(lower[0]) <= exact <= Fraction(upper[0])
    assert upper[0] - lower[0] < 1e-14
    # infeasible row
    lower, upper = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    assert contract_linear(M, np.array([3.0]), np.array([3.0]), lower, upper)
    # inequalities: x + y <= 0.5 on [0, 1]^2
    lower, upper = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    assert not contract_linear(M, np.array([-np.inf]), np.array([0.5]), lower, upper)
    assert lower.tolist() == [0.0, 0.0] and 0.5 <= upper[0] < 0.5 + 1e-15


def test_bernstein_contraction_uses_the_convex_hull():
    coeffs = np.array([[0.0, 1.0], [1.0, 2.0]])  # f = u + v
    system = make_system(["u", "v", "F"], [0.25, 0.5, -5], [0.5, 0.75, 5],
                         bernstein=[BernsteinEquation(2, 0, 1, coeffs)])
    lo, hi, empty = contract(system, system.lower, system.upper)
    assert not empty and 0.75 - 1e-12 < lo[2] <= 0.75 and 1.25 <= hi[2] < 1.25 + 1e-12


def test_options_are_validated():
    with pytest.raises(ValueError):
        ShrinkOptions(rho=0.0)
    with pytest.raises(ValueError):
        ShrinkOptions(size="volume")
    with pytest.raises(ValueError):
        ShrinkOptions(lp_time_limit=0)
    with pytest.raises(ValueError):
        ShrinkOptions(lp_order="random")
    with pytest.raises(ValueError):
        ShrinkOptions(stop_after=-1)
    system = circle_line()
    with pytest.raises(ValueError):
        shrink_box(system, np.zeros(3), np.ones(3))
    res = shrink_box(system, system.lower, system.upper, ShrinkOptions(size="sum", rho=0.99, max_passes=50))
    assert not res.empty and np.all(res.upper - res.lower < 1e-9)


def test_checkpoint_fingerprint_leaves_out_the_cheaper_passes_at_their_old_values():
    """A search with the pass options at the values of the search before them keeps the old
    fingerprint (a checkpoint written before them resumes); set otherwise, they are part of it."""
    from prehension.solvers.complete.checkpoint import _options_mapping
    from prehension.solvers.complete.search import BranchAndPruneOptions

    old = _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions()))
    assert not {"shrink.feasibility_first", "shrink.lp_order", "shrink.stop_after", "shrink.stop_gain"} & set(old)
    for change in ({"feasibility_first": True}, {"lp_order": "narrowest"}, {"stop_after": 5}):
        new = _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(**change)))
        key = "shrink." + next(iter(change))
        assert new[key] == next(iter(change.values())) and new != old
    assert "shrink.stop_gain" in _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(stop_after=5)))
