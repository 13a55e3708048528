"""The pose-free pair test (solvers/complete/pair/) and its affine forms: the
enclosures contain what they bound, a known solution is never pruned, and proofs end the
complete search as infeasible."""

from __future__ import annotations

import numpy as np
import pytest

from fk_tasks import build_fk_case
from prehension.geometry.regions import PointRegion
from prehension.hands.sa_hand import schunk_sa_hand
from prehension.objects.model import GraspObject
from prehension.results import Status
from prehension.solvers.complete.pair import affine as af
from prehension.solvers.complete import pair as cg
from prehension.solvers.complete.pair import forms as pf
from prehension.solvers.complete.pair import product
from prehension.solvers.complete.pair import span as ps
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Contact, Task
from prehension.solvers.local.verifier import LocalVerifier


# -- affine forms --------------------------------------------------------------------------------
def _random_form(rng, B, K, vector=True):
    shape = (B, 3) if vector else (B,)
    return af.Form(rng.normal(size=shape) * 10, rng.normal(size=shape + (K,)), rng.uniform(0, 2, B))


def _sample(rng, f: af.Form, eps):
    """A value the form allows: ``c + A eps + r`` with ``|r| <= rho``."""
    if f.c.ndim == 2:
        r = rng.normal(size=f.c.shape)
        r *= (f.rho * rng.uniform(0, 1, len(r)) / np.linalg.norm(r, axis=1))[:, None]
        return f.c + np.einsum("bik,bk->bi", f.A, eps) + r
    return f.c + np.einsum("bk,bk->b", f.A, eps) + f.rho * rng.uniform(-1, 1, len(f.c))


def _contains(f: af.Form, value, eps):
    linear = f.c + (np.einsum("bik,bk->bi", f.A, eps) if f.c.ndim == 2 else np.einsum("bk,bk->b", f.A, eps))
    gap = np.linalg.norm(value - linear, axis=1) if f.c.ndim == 2 else np.abs(value - linear)
    return np.all(gap <= f.rho * (1 + 1e-9) + 1e-9 * (1 + np.abs(value).max()))


@pytest.mark.parametrize("seed", range(20))
def test_products_of_affine_forms_contain_the_products(seed):
    rng = np.random.default_rng(seed)
    B, K = 64, 5
    u, w = _random_form(rng, B, K), _random_form(rng, B, K)
    eps = rng.uniform(-1, 1, (B, K))
    uu, ww = _sample(rng, u, eps), _sample(rng, w, eps)
    assert _contains(af.dot(u, w), np.einsum("bi,bi->b", uu, ww), eps)
    assert _contains(af.cross(u, w), np.cross(uu, ww), eps)
    assert _contains(af.sub(u, w), uu - ww, eps)
    s = af.dot(u, w)
    value = np.einsum("bi,bi->b", uu, ww)
    assert np.all(np.abs(value - s.c) <= af.spread(s) * (1 + 1e-9) + 1e-9)


@pytest.mark.parametrize("seed", range(10))
def test_the_dot_product_form_contains_the_products_at_the_corners_and_lies_in_the_product_bound(seed):
    rng = np.random.default_rng(100 + seed)
    B, K = 64, 6
    u, w = _random_form(rng, B, K), _random_form(rng, B, K)
    s = af.dot(u, w)
    for _ in range(20):  # corners of the eps box, where the quadratic terms are extreme, and inside
        eps = rng.choice([-1.0, 1.0], size=(B, K)) if _ % 2 else rng.uniform(-1, 1, (B, K))
        uu, ww = _sample(rng, u, eps), _sample(rng, w, eps)
        assert _contains(s, np.einsum("bi,bi->b", uu, ww), eps)
    # inside the enclosure of the product bound (|u_c| rho_w + |w_c| rho_u + (sum|U| + rho_u)(sum|W| + rho_w))
    c_old = np.einsum("bi,bi->b", u.c, w.c)
    su, sw = np.linalg.norm(u.A, axis=1).sum(axis=1), np.linalg.norm(w.A, axis=1).sum(axis=1)
    rho_old = (np.linalg.norm(u.c, axis=1) * w.rho + np.linalg.norm(w.c, axis=1) * u.rho
               + (su + u.rho) * (sw + w.rho))  # fmt: skip
    assert np.all(np.abs(s.c - c_old) + s.rho <= rho_old * (1 + 1e-12) + 1e-9)


def test_the_dot_product_form_is_exact_for_forms_varying_in_orthogonal_directions():
    """u = (1 + 2 eps_0, 1, 0) and w = (1, 1 + 3 eps_1, 0): u . w = 2 + 2 eps_0 + 3 eps_1 exactly
    (the product bound would add a remainder of 2 * 3 = 6)."""
    A_u, A_w = np.zeros((1, 3, 2)), np.zeros((1, 3, 2))
    A_u[0, 0, 0], A_w[0, 1, 1] = 2.0, 3.0
    u = af.Form(np.array([[1.0, 1.0, 0.0]]), A_u, np.zeros(1))
    w = af.Form(np.array([[1.0, 1.0, 0.0]]), A_w, np.zeros(1))
    s = af.dot(u, w)
    assert s.rho[0] == 0.0 and s.c[0] == 2.0
    np.testing.assert_allclose(s.A[0], [2.0, 3.0])


def test_contraction_keeps_every_zero_of_the_form():
    rng = np.random.default_rng(0)
    for _ in range(200):
        K = 4
        A = rng.normal(size=(1, K))
        eps = rng.uniform(-1, 1, (1, K))
        rho = rng.uniform(0, 0.5, 1)
        r = rho * rng.uniform(-1, 1)
        c = -(A @ eps[0]) - r  # c + A eps + r = 0 at eps
        lo, hi = -np.ones((1, K)), np.ones((1, K))
        af.contract_equal(af.Form(c, A, rho), np.zeros(1), lo, hi)
        assert np.all(lo <= eps) and np.all(eps <= hi)


# -- the pair problems ----------------------------------------------------------------------------
def _pinch_task(width_mm: float) -> Task:
    obj = GraspObject("two-points", {"a": PointRegion((0, 0, 0), (-1, 0, 0)), "b": PointRegion((width_mm, 0, 0), (1, 0, 0))})
    return Task("pinch", schunk_sa_hand(), obj, (Contact("thumb_tip", "a"), Contact("index_tip", "b")), ("thumb", "index"))


def _pair_problems():
    rng = np.random.default_rng(3)
    hand = schunk_sa_hand()
    cases = [(_pinch_task(60.0), None), (load_builtin_task("teapot-lid-lifting"), None)]
    for kinds in (("cap", "bezier"), ("point", "cap"), ("bezier", "bezier")):
        case = build_fk_case(hand, rng, fingers=("thumb", "index"), palm=False, kinds=kinds)
        cases.append((case.task, case.config))
    return cases


def _true_values(pp: cg.PairProblem, z: np.ndarray):
    """``(d_hand, m_a, m_b, d_obj, h_a, h_b)`` at points ``z (B, K)`` of the pair's box."""
    d, _, Ra, _, Rb, _ = pp.kin.evaluate(z[:, pp.slices[0]])
    dirs = []
    for side, R in ((0, Ra), (1, Rb)):
        region = pp.hand[side][0].region
        v = region.axis if hasattr(region, "axis") else region.normal
        dirs.append(np.einsum("bij,j->bi", R, v))
    centres, normals = [], []
    for side in (0, 1):
        region, radius = pp.objects[side][0], pp.hand[side][1]
        o, nu = region.evaluate(z[:, pp.slices[1 + side]])
        centres.append(o + radius * nu)
        normals.append(-nu)
    return -d, dirs[0], dirs[1], centres[1] - centres[0], normals[0], normals[1]


@pytest.mark.parametrize("case", range(5))
def test_the_forms_of_both_sides_contain_their_values_on_random_boxes(case):
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    assert pp is not None
    rng = np.random.default_rng(case)
    B = 200
    width = (pp.upper - pp.lower) * 10.0 ** rng.uniform(-3, 0, (B, 1))
    lo = pp.lower + rng.uniform(0, 1, (B, pp.n_dims)) * (pp.upper - pp.lower - width)
    hi = lo + width
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d_hand, dirs = pf.hand_forms(pp, zc, half)
    d_obj, h_a, h_b = pf.object_forms(pp, zc, half)
    forms = (d_hand, dirs[0], dirs[1], d_obj, h_a, h_b)
    for _ in range(10):
        eps = rng.uniform(-1, 1, (B, pp.n_dims))
        for form, value in zip(forms, _true_values(pp, zc + half * eps)):
            assert _contains(form, value, eps)


@pytest.mark.parametrize("case", [2, 3, 4])
def test_boxes_around_a_known_solution_are_never_pruned(case):
    """Forward-built tasks: every box holding the known solution survives pruning and its
    contraction, whatever its size (the pair test never loses a solution)."""
    task, config = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    z = np.concatenate([config.joint_angles[pp.kin.problem.sources]] + [np.atleast_1d(config.contact_params[i][1]) for i in (0, 1)])
    assert np.all(z >= pp.lower - 1e-12) and np.all(z <= pp.upper + 1e-12)
    rng = np.random.default_rng(case)
    B = 300
    width = (pp.upper - pp.lower) * 10.0 ** rng.uniform(-6, 0, (B, 1))
    lo = np.maximum(pp.lower, z - rng.uniform(0, 1, (B, pp.n_dims)) * width)
    hi = np.minimum(pp.upper, lo + width)
    hi = np.maximum(hi, z)
    kept_lo, kept_hi, _, _ = product._prune_and_contract(pp, lo, hi)
    assert len(kept_lo) == B
    assert np.all(kept_lo <= z) and np.all(z <= kept_hi)


def test_every_pair_of_a_forward_built_task_with_the_palm_keeps_its_solution():
    rng = np.random.default_rng(7)
    case = build_fk_case(schunk_sa_hand(), rng, fingers=("thumb", "index", "middle"), palm=True)
    task, config = case.task, case.config
    for a in range(len(task.contacts)):
        for b in range(a + 1, len(task.contacts)):
            pp = cg.pair_problem(task, a, b)
            z = np.concatenate([config.joint_angles[pp.kin.problem.sources]]
                               + [np.atleast_1d(config.contact_params[i][1]) for i in (a, b)])  # fmt: skip
            width = (pp.upper - pp.lower) * 10.0 ** rng.uniform(-6, 0, (100, 1))
            lo = np.maximum(pp.lower, z - rng.uniform(0, 1, (100, pp.n_dims)) * width)
            hi = np.maximum(np.minimum(pp.upper, lo + width), z)
            kept_lo, kept_hi, _, _ = product._prune_and_contract(pp, lo, hi)
            assert len(kept_lo) == 100 and np.all(kept_lo <= z) and np.all(z <= kept_hi)


def test_forward_built_pairs_are_never_proved_infeasible():
    for task, config in _pair_problems()[2:]:
        outcome = product.prove_pair_infeasible(cg.pair_problem(task, 0, 1), max_boxes=3000)
        assert not outcome.proved


@pytest.mark.parametrize("case", range(5))
def test_the_object_distance_range_contains_the_distances_on_random_boxes(case):
    """The object side's |c_b - c_a| bounds of the span test hold at sampled points of many
    seeded random boxes (patches, caps, points; boxes from the whole domain to 1e-3 of it)."""
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    rng = np.random.default_rng(100 + case)
    B = 200
    width = (pp.upper - pp.lower) * 10.0 ** rng.uniform(-3, 0, (B, 1))
    lo = pp.lower + rng.uniform(0, 1, (B, pp.n_dims)) * (pp.upper - pp.lower - width)
    hi = lo + width
    lower, upper = ps.object_distance_range(pp, lo, hi)
    for _ in range(20):
        z = lo + rng.uniform(0, 1, lo.shape) * (hi - lo)
        distance = np.linalg.norm(_true_values(pp, z)[3], axis=1)
        assert np.all(lower <= distance * (1 + 1e-12)) and np.all(distance <= upper * (1 + 1e-12))


def test_forward_built_pairs_are_never_proved_out_of_span():
    hand = schunk_sa_hand()
    for task, _ in _pair_problems()[2:]:
        assert not ps.prove_out_of_span(cg.pair_problem(task, 0, 1), hand).proved


def test_the_span_test_proves_a_pinch_wider_than_the_span_and_not_one_within_it():
    pp = cg.pair_problem(_pinch_task(60.0), 0, 1)
    span = ps.pair_span_mm(pp, schunk_sa_hand(), tight=True)
    extra = ps.object_distance_range(pp, pp.lower[None], pp.upper[None])[0][0] - 60.0  # the fingertip radii
    assert ps.prove_out_of_span(cg.pair_problem(_pinch_task(span - extra + 0.01), 0, 1), schunk_sa_hand()).proved
    outcome = ps.prove_out_of_span(cg.pair_problem(_pinch_task(span - extra - 0.01), 0, 1), schunk_sa_hand())
    assert not outcome.proved and outcome.stopped == "witness"


@pytest.mark.parametrize("case", range(5))
def test_the_object_distance_floor_is_below_every_distance(case):
    task, _ = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    floor, best, boxes = ps.object_distance_floor(pp, max_boxes=300)
    rng = np.random.default_rng(200 + case)
    z = pp.lower + rng.uniform(0, 1, (2000, pp.n_dims)) * (pp.upper - pp.lower)
    distance = np.linalg.norm(_true_values(pp, z)[3], axis=1)
    assert floor <= distance.min() and floor <= best and boxes <= 300 + 2 * 64


@pytest.mark.parametrize("case", [2, 3, 4])
def test_boxes_around_a_known_solution_survive_the_distance_floor(case):
    """As above, with the object side's floor: the hand's distance bound never discards the
    box of a known solution."""
    task, config = _pair_problems()[case]
    pp = cg.pair_problem(task, 0, 1)
    floor, _, _ = ps.object_distance_floor(pp)
    z = np.concatenate([config.joint_angles[pp.kin.problem.sources]] + [np.atleast_1d(config.contact_params[i][1]) for i in (0, 1)])
    rng = np.random.default_rng(300 + case)
    B = 300
    width = (pp.upper - pp.lower) * 10.0 ** rng.uniform(-6, 0, (B, 1))
    lo = np.maximum(pp.lower, z - rng.uniform(0, 1, (B, pp.n_dims)) * width)
    hi = np.maximum(np.minimum(pp.upper, lo + width), z)
    kept_lo, kept_hi, _, _ = product._prune_and_contract(pp, lo, hi, floor)
    assert len(kept_lo) == B and np.all(kept_lo <= z) and np.all(z <= kept_hi)


def test_the_hand_distance_bound_contains_the_distances_on_random_boxes():
    pp = cg.pair_problem(load_builtin_task("teapot-lid-lifting"), 0, 1)
    sa = pp.slices[0]
    rng = np.random.default_rng(5)
    B = 300
    lo_all, hi_all = pp.lower[sa], pp.upper[sa]
    width = (hi_all - lo_all) * 10.0 ** rng.uniform(-3, 0, (B, 1))
    lo = lo_all + rng.uniform(0, 1, (B, len(lo_all))) * (hi_all - lo_all - width)
    hi = lo + width
    upper, score = pp.kin.distance_upper_mm(lo, hi)
    assert score.shape == lo.shape and np.all(score >= 0)
    for _ in range(20):
        d, _ = pp.kin.difference(lo + rng.uniform(0, 1, lo.shape) * (hi - lo))
        assert np.all(np.linalg.norm(d, axis=1) <= upper * (1 + 1e-12))


def test_a_pinch_past_reach_is_proved_and_ends_the_search_as_infeasible():
    proof = product.prove_pair_infeasible(cg.pair_problem(_pinch_task(180.0), 0, 1), max_boxes=50_000)
    assert proof.proved
    seen = []
    result = solve_complete(_pinch_task(180.0), BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=50), progress=seen.append)
    assert result.status == Status.INFEASIBLE
    assert "cannot be made together whatever the object's pose" in result.message
    assert result.stats["pair_test"]["proved"]
    assert any("pair test" in info for info in seen)  # the progress line says the pair test runs


def test_the_pair_test_stops_at_its_time_limit():
    import time

    pp = cg.pair_problem(load_builtin_task("teapot-lid-lifting"), 0, 1)
    started = time.perf_counter()
    outcome = product.prove_pair_infeasible(pp, max_boxes=10**9, time_limit_s=0.5)
    assert not outcome.proved and outcome.stopped == "budget"
    assert time.perf_counter() - started < 5.0


# -- the twist about the line between the fingertip centres ----------------------------------------
class _Caps:
    """The stand-in of a PairProblem that :func:`product.twist_possible` reads: two hand caps."""

    def __init__(self, betas):
        from prehension.geometry.regions import SphereCap

        self.hand = tuple((type("H", (), {"region": SphereCap((0, 0, 0), 10.0, (0, 0, 1), b)})(), 10.0) for b in betas)
        self.betas = tuple(float(b) for b in betas)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _rotate(v, axis, angle):
    axis = _unit(axis)
    return (v * np.cos(angle)[:, None] + np.cross(axis, v) * np.sin(angle)[:, None]
            + axis * np.einsum("bi,bi->b", axis, v)[:, None] * (1 - np.cos(angle))[:, None])  # fmt: skip


def _twist_case(rng, B, feasible):
    """Hand side ``d, m_a, m_b`` and object side ``d, h_a, h_b`` (B, 3) and the cap angles: with
    ``feasible``, ``h_i`` is ``R m_i`` turned by at most ``beta_i`` (``R d_hand = d_obj``)."""
    betas = rng.uniform(0.1, 1.4, 2)
    d_hand = rng.normal(size=(B, 3)) * 60.0
    m = [_unit(rng.normal(size=(B, 3))) for _ in range(2)]
    axis, angle = rng.normal(size=(B, 3)), rng.uniform(0, np.pi, B)
    d_obj = _rotate(d_hand, axis, angle)
    if feasible:
        h = [_rotate(_rotate(m[s], axis, angle), np.cross(m[s], rng.normal(size=(B, 3))), betas[s] * rng.uniform(0.9, 1.0, B))
             for s in range(2)]  # fmt: skip
    else:
        h = [_unit(rng.normal(size=(B, 3))) for _ in range(2)]
    return betas, d_hand, m, d_obj, h


def _best_twist_slack(betas, d_hand, m, d_obj, h):
    """``max over psi of min_i (beta_i - angle(R_psi m_i, h_i))`` by a scan of the twist (B,)."""
    B = len(d_hand)
    u_h, u_o = _unit(d_hand), _unit(d_obj)
    axis = np.cross(u_h, u_o)
    angle = np.arctan2(np.linalg.norm(axis, axis=1), np.einsum("bi,bi->b", u_h, u_o))
    best = np.full(B, -np.inf)
    for psi in np.linspace(-np.pi, np.pi, 7201):
        slack = np.full(B, np.inf)
        for s in range(2):
            v = _rotate(_rotate(m[s], axis, angle), u_o, np.full(B, psi))
            slack = np.minimum(slack, betas[s] - np.arccos(np.clip(np.einsum("bi,bi->b", v, h[s]), -1, 1)))
        best = np.maximum(best, slack)
    return best


def _enclosing_form(rng, value, K, size):
    """A random affine form around ``value (B, 3)`` with ``value`` inside (its eps and remainder drawn)."""
    B = len(value)
    A = rng.normal(size=(B, 3, K)) * size[:, None, None]
    rho = rng.uniform(0, 1, B) * size
    eps = rng.uniform(-1, 1, (B, K))
    r = _unit(rng.normal(size=(B, 3))) * (rho * rng.uniform(0, 1, B))[:, None]
    return af.Form(value - np.einsum("bik,bk->bi", A, eps) - r, A, rho)


@pytest.mark.parametrize("seed", range(6))
def test_the_twist_condition_keeps_every_pair_that_one_rotation_can_make(seed):
    """Both cones met by one rotation (the normals turned by up to their cap angles): no box
    holding the values is pruned, whatever its size."""
    rng = np.random.default_rng(seed)
    B, K = 400, 4
    betas, d_hand, m, d_obj, h = _twist_case(rng, B, feasible=True)
    size = 10.0 ** rng.uniform(-9, -1, B)
    forms = [_enclosing_form(rng, v, K, size * scale) for v, scale in ((d_hand, 60.0), (m[0], 1.0), (m[1], 1.0),
                                                                       (d_obj, 60.0), (h[0], 1.0), (h[1], 1.0))]  # fmt: skip
    kept = product.twist_possible(_Caps(betas), forms[0], forms[1:3], forms[3], tuple(forms[4:]))
    assert kept.all()


@pytest.mark.parametrize("seed", [0, 1] + [pytest.param(s, marks=pytest.mark.slow) for s in (2, 3)])
def test_the_twist_condition_prunes_exact_values_that_no_rotation_can_make(seed):
    """Random normals: at points (boxes of width 0) the condition is exact -- it prunes
    exactly the cases where no twist meets both cones (by a scan of the twist), beyond a
    margin of 0.01 rad."""
    rng = np.random.default_rng(100 + seed)
    B = 300
    betas, d_hand, m, d_obj, h = _twist_case(rng, B, feasible=False)
    best = _best_twist_slack(betas, d_hand, m, d_obj, h)
    point = lambda v: af.Form(v, np.zeros(v.shape + (1,)), np.zeros(len(v)))  # noqa: E731
    kept = product.twist_possible(_Caps(betas), point(d_hand), [point(m[0]), point(m[1])], point(d_obj), (point(h[0]), point(h[1])))
    assert np.all(kept[best > 1e-2])
    assert not np.any(kept[best < -1e-2])
    assert (best < -1e-2).sum() > 20  # the cases do test pruning
