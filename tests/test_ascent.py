"""The quality ascent: verified grasps moved along their solution set to a higher epsilon."""

from __future__ import annotations

import numpy as np
import pytest

import prehension.ascent as ascent_module
from box_example import box_grasps
from prehension.ascent import AscentOptions, improve_grasp, merit
from prehension.ascent.manifold import GraspChart
from prehension.ascent.surrogate import support_surrogate
from prehension.best import BestOptions, solve_best
from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, grasp_quality, hull_facets, primitive_wrenches, torque_reference
from prehension.quality.measures import force_closure, hull_measures
from prehension.solve import SolveOptions, solve
from prehension.tasks.library import load_builtin_task
from prehension.verification.residuals import evaluate



@pytest.fixture(scope="module")
def box():
    return box_grasps.four_finger_grasp()  # (task, verified solution), epsilon 0.061


@pytest.fixture(scope="module")
def chart(box):
    task, solution = box
    chart, z = GraspChart.at(task, solution.configuration(), torque_reference(task)[1])
    return chart, z, solution.T_palm_object.copy()


def test_the_chart_reads_the_grasp_back_and_its_jacobian_matches_central_differences(box, chart):
    task, solution = box
    ch, z, T = chart
    config = ch.configuration(z, T)
    assert np.allclose(config.joint_angles, solution.q) and evaluate(task, config).ok
    F, J = ch.jacobian(z, T)
    assert np.max(np.abs(F)) < 1e-6
    n = ch.nz + 6
    for j in range(n):
        d = np.zeros(n)
        d[j] = 1e-4 / ch.scale[j]
        plus, minus = ch.step(z, T, d), ch.step(z, T, -d)
        if not (np.array_equal(plus[0] - z, d[: ch.nz]) and np.array_equal(z - minus[0], d[: ch.nz])):
            continue  # at a bound: the step was clipped
        central = (ch.residuals(plus[0][None], plus[1][None])[0] - ch.residuals(minus[0][None], minus[1][None])[0]) / (2 * d[j])
        assert np.allclose(J[:, j], central, rtol=1e-4, atol=1e-4 * max(1.0, np.abs(central).max())), j


def test_a_tangent_step_leaves_the_set_to_second_order_and_projection_returns_to_it(box, chart):
    task, solution = box
    ch, z, T = chart
    _, J = ch.jacobian(z, T)
    gradient = np.zeros(ch.nz + 6)
    for s in ch.object_slices():
        gradient[s] = 0.5 - z[s]  # toward the middle of each patch: no bound on the way
    gaps = []
    for radius in (0.4, 0.2, 0.1):
        d = ch.tangent(z, J, gradient, radius)
        assert np.linalg.norm(d * ch.scale) == pytest.approx(radius)
        z1, T1 = ch.step(z, T, d)
        gaps.append(np.max(np.abs(ch.residuals(z1[None], T1[None])[0])))
    assert gaps[0] > gaps[1] > gaps[2] and gaps[1] / gaps[2] > 3.0  # O(r^2), not O(r)
    z1, T1 = ch.step(z, T, ch.tangent(z, J, gradient, 2.0))
    z2, T2, converged = ch.project(z1, T1, J)
    assert converged and evaluate(task, ch.configuration(z2, T2)).ok


def test_the_surrogate_tracks_epsilon_and_bounds_it_from_above():
    """At a grasp, the hard surrogate (tau -> 0) is its epsilon; moved, it never falls below
    the moved grasp's epsilon; the soft one lies within tau log(F K) of the hard one."""
    rng = np.random.default_rng(11)
    options = QualityOptions()
    checked = 0
    for _ in range(30):
        n = rng.normal(size=(4, 3))
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        points, inward = 50.0 * n, -n
        W = primitive_wrenches(points, inward, np.zeros(3), 50.0, options).reshape(-1, 6)
        if not force_closure(W).force_closure:
            continue
        normals, _ = hull_facets(W)
        eps = hull_measures(W)[0]
        tau = 1e-4
        hard = support_surrogate(points[None], inward[None], np.zeros(3), 50.0, options, normals, tau)[0]
        assert abs(hard - eps) <= tau * np.log(len(normals) * len(W)) + 1e-12
        soft = support_surrogate(points[None], inward[None], np.zeros(3), 50.0, options, normals, 0.01)[0]
        assert abs(soft - hard) <= 0.01 * np.log(len(normals) * len(W)) + 1e-9
        moved_n = n + 0.05 * rng.normal(size=n.shape)
        moved_n /= np.linalg.norm(moved_n, axis=1, keepdims=True)
        W2 = primitive_wrenches(50.0 * moved_n, -moved_n, np.zeros(3), 50.0, options).reshape(-1, 6)
        bound = support_surrogate(50.0 * moved_n[None], -moved_n[None], np.zeros(3), 50.0, options, normals, tau)[0]
        assert bound + tau * np.log(len(W)) >= hull_measures(W2)[0] - 1e-12
        checked += 1
    assert checked >= 5


@pytest.mark.parametrize("quality", [QualityOptions(), QualityOptions(torsion_mm=5.0)], ids=["hard", "soft"])
def test_the_ascent_raises_epsilon_and_returns_a_verified_grasp(box, quality):
    task, solution = box
    up = improve_grasp(task, solution, quality, AscentOptions(steps=12))
    assert up.start.epsilon == grasp_quality(task, solution, quality).epsilon
    # 1.18x (hard) and 1.24x (soft) in 12 steps: steps that would put a distal capsule into the
    # box beyond its pad (the pad rule, docs/objects.md) are rejected, so the gain is smaller
    # than the 1.29x measured before that rule.
    assert up.accepted >= 1 and up.quality.epsilon > 1.15 * up.start.epsilon
    assert evaluate(task, up.solution.configuration()).ok  # strict tolerances
    assert up.quality == grasp_quality(task, up.solution, quality)
    assert merit(task, up.solution, quality) == pytest.approx(up.quality.epsilon, abs=1e-12)


def test_a_step_that_fails_verification_is_never_returned(box, monkeypatch):
    task, solution = box
    monkeypatch.setattr(ascent_module, "make_solution", lambda task, config: None)
    up = improve_grasp(task, solution, QualityOptions(), AscentOptions(steps=5))
    assert up.solution is solution and up.accepted == 0 and up.tried >= 1


def test_a_grasp_that_is_not_force_closure_moves_toward_it():
    """Merit below 0 (the origin outside the wrench hull) rises; what is returned is verified."""
    task = load_builtin_task("scalpel-handling")
    grasp = solve(task, "local").solutions[0]
    start = merit(task, grasp)
    assert start < 0
    up = improve_grasp(task, grasp, QualityOptions(), AscentOptions(steps=6))
    assert up.accepted >= 1 and merit(task, up.solution) > start and evaluate(task, up.solution.configuration()).ok


def test_a_flat_wrench_set_has_nothing_to_climb():
    """Every contact on one face: every wrench has the same normal force, so they lie in a
    hyperplane; no facets, no gradient, the grasp comes back as it was."""
    task, grasp = box_grasps.one_face_grasp()
    up = improve_grasp(task, grasp)
    assert merit(task, grasp) == 0.0 and up.solution is grasp and up.tried == 0


@pytest.mark.parametrize("kwargs, message", [
    ({"steps": -1}, "steps must be an integer >= 0"),
    ({"radius_mm": 0.0}, "radius_mm must be a positive number"),
    ({"temperature": float("nan")}, "temperature must be a positive number"),
    ({"time_limit_s": 0.0}, "time_limit_s must be > 0"),
])  # fmt: skip
def test_bad_ascent_options_are_refused(kwargs, message):
    with pytest.raises(PrehensionError, match=message):
        AscentOptions(**kwargs)


def test_best_of_many_improves_what_it_finds(box):
    task, _ = box
    found = solve_best(task, BestOptions(n=3, starts=30, ascent=None), SolveOptions(method="local", seed=2))
    improved = solve_best(task, BestOptions(n=3, starts=30, ascent=AscentOptions(steps=8)), SolveOptions(method="local", seed=2))
    eps = improved.stats["best"]["epsilon"]
    assert eps == sorted(eps, reverse=True) and eps[0] >= found.stats["best"]["epsilon"][0]
    for s, up in zip(improved.solutions, improved.stats["best"]["ascent"]):
        assert evaluate(task, s.configuration()).ok
        assert grasp_quality(task, s).epsilon >= up["epsilon_before"]
    assert all(a is None for a in found.stats["best"]["ascent"])


def test_on_forward_built_tasks_the_ascent_never_lowers_the_merit_and_returns_verified_grasps(sa_hand):
    """Seeded forward-built tasks (point, patch and cap regions on the object, fingertip caps
    and the palm on the hand), hard and soft fingers: what comes back passes the strict
    residual function and its merit is at least the start's; on several it rises."""
    from fk_tasks import build_fk_case

    from prehension.results import make_solution

    rose = tried = 0
    for seed in range(20):
        case = build_fk_case(sa_hand, np.random.default_rng(seed))
        grasp = make_solution(case.task, case.config)
        if grasp is None:  # the forward-built pose collides: not a grasp to start from
            continue
        for quality in (QualityOptions(), QualityOptions(torsion_mm=5.0)):
            up = improve_grasp(case.task, grasp, quality, AscentOptions(steps=4))
            assert evaluate(case.task, up.solution.configuration()).ok
            start, end = merit(case.task, grasp, quality), merit(case.task, up.solution, quality)
            assert end >= start
            tried += 1
            rose += end > start
    assert tried >= 10 and rose >= 5


def test_a_contact_near_its_cones_edge_does_not_cut_the_step_to_a_sliver(box, chart):
    """A fingertip contact 0.01 mm-worth inside its cap's cone, the objective pushing it out:
    the cone is kept (the step slides along it) and the step keeps its length, instead of
    stopping at the sliver left before the edge (the ascent then crawled: 20 steps of 0.0 mm)."""
    ch, z, T = chart
    assert ch.cones
    k, region = ch.cones[0]
    _, grad = region.cone_margin(z[k : k + 2])
    outward = -np.asarray(grad, float) / np.linalg.norm(grad)
    lo, hi = 0.0, 1.0  # the cap parameter on the cone's edge along ``outward``, by bisection
    while region.cone_margin(z[k : k + 2] + hi * outward)[0] >= 0.0:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if region.cone_margin(z[k : k + 2] + mid * outward)[0] >= 0.0 else (lo, mid)
    near = z.copy()
    near[k : k + 2] += lo * outward - 1e-2 * outward / ch.scale[k : k + 2]
    assert 0.0 < region.cone_margin(near[k : k + 2])[0]
    _, J = ch.jacobian(near, T)
    gradient = np.zeros(ch.nz + 6)
    gradient[k : k + 2] = outward * ch.scale[k : k + 2]
    d = ch.tangent(near, J, gradient, 2.0)
    assert np.linalg.norm(d * ch.scale) > 1.0  # not a sliver of the 2 mm asked
    assert region.cone_margin(near[k : k + 2] + d[k : k + 2])[0] >= 0.0
