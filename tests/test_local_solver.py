"""The local solver (Claret & Suárez): Jacobians, steps, solutions that re-verify, give-ups."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fk_tasks import build_fk_case
from prehension.errors import PrehensionError
from prehension.geometry.regions import BezierRegion, SphereCap
from prehension.hands.collision import capsule_clearances
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.model import GraspObject
from prehension.results import Status, make_solution
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Task
from prehension.verification.residuals import Tolerances, coupling_violations, evaluate, limit_violations
from prehension.solvers.local import (
    LocalOptions,
    PointProblems,
    random_point_problems,
    solve_local,
    refine_local,
    solve_local_batch,
)
from prehension.solvers.local import _kernel as K
from prehension.solvers.local import _regions as RG
from prehension.solvers.local._layout import S_K, S_X
from prehension.solvers.local._linalg import dls_again, dls_dense, refresh_column
from prehension.solvers.local.problems import group_from_tasks

DEG = np.pi / 180.0


# -- helpers: the kernel's residual at a state ----------------------------------------------
def _rodrigues(w):
    """The rotation of the rotation vector ``w`` (scipy's, independent of the kernel's)."""
    return Rotation.from_rotvec(w).as_matrix()


class _State:
    """Call the kernel's residual/Jacobian from Python for one problem of a group."""

    def __init__(self, group, problem=0, wn=25.0):
        self.g = group
        self.data = group.pdata[problem]
        self.piv = self.data[group.layout.pivot_offset : group.layout.pivot_offset + 3]
        self.opt = LocalOptions(normal_weight_mm=wn).kernel_options()

    def residual(self, x, R, t, jac=True):
        C, nx = len(self.g.contacts), self.g.nx
        f, J = np.zeros(6 * C), np.zeros((6 * C, nx))
        K.residual_at(x, R, t, self.data, (self.g.arrays, self.g.layout, self.opt, self.g.obj), f, J)
        return f, J

    def moved(self, x, R, t, dx):
        """The state moved by ``dx``: the object by its twist about the pivot, the rest added."""
        nf = self.g.nf
        cp = R @ self.piv + t
        Rn = _rodrigues(dx[nf : nf + 3]) @ R
        tn = cp + dx[nf + 3 : nf + 6] - Rn @ self.piv
        xn = x + np.where((np.arange(self.g.nx) < nf) | (np.arange(self.g.nx) >= nf + 6), dx, 0.0)
        return xn, Rn, tn


def _state_from_case(case, group):
    """Unknowns x and pose (R, t) of an FK case's known configuration."""
    x = group.x_default.copy()
    x[: group.nf] = case.config.joint_angles[list(group.free)]
    for c, (h, o) in enumerate(case.config.contact_params):
        (xh, kh), (xo, ko) = group.layout.sides[c, 0, [S_X, S_K]], group.layout.sides[c, 1, [S_X, S_K]]
        x[xh : xh + kh], x[xo : xo + ko] = h, o
    T = case.config.T_palm_object
    return x, T[:3, :3].copy(), T[:3, 3].copy()


def _check_solution(task, sol):
    """Everything the issue asks of a returned solution, with the foundation's functions."""
    hand = task.hand
    q = sol.q
    assert np.degrees(coupling_violations(hand, q)).max(initial=0.0) <= 1e-9
    assert np.degrees(limit_violations(hand, q)).max() <= 1e-9
    clearance, _ = capsule_clearances(hand, forward_kinematics(hand, q))
    assert clearance.min() >= 0.0
    report = evaluate(task, sol.configuration(), Tolerances(contact_mm=1.5, normal_deg=5.0))
    assert report.ok, report.summary()


# -- the kernel --------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_jacobian_matches_finite_differences(sa_hand, seed):
    rng = np.random.default_rng(seed)
    case = build_fk_case(sa_hand, rng, fingers=("thumb", "index", "middle"), palm=True, kinds=("bezier", "cap", "point", "bezier"))
    group = group_from_tasks([case.task])
    st = _State(group)
    x, R, t = _state_from_case(case, group)
    x[: group.nf] += rng.uniform(-0.1, 0.1, group.nf)  # away from the solution
    x = np.clip(x, group.layout.lo, group.layout.hi)
    f, J = st.residual(x, R, t)
    h = 1e-6
    Jn = np.zeros_like(J)
    for k in range(group.nx):
        e = np.zeros(group.nx)
        e[k] = h
        fp = st.residual(*st.moved(x, R, t, e), jac=False)[0]
        fm = st.residual(*st.moved(x, R, t, -e), jac=False)[0]
        Jn[:, k] = (fp - fm) / (2 * h)
    np.testing.assert_allclose(J, Jn, atol=2e-5 * max(1.0, np.abs(J).max()))


def _kernel_region(region, prm):
    kind, m, n, _ = RG.code(region)
    ws = RG.RegionScratch.allocate()  # a package type: numba's cache index must not name a test module
    side = np.array([kind, 0, m, n, 0, len(prm)], dtype=np.int64)
    RG.evaluate(side, RG.pack(region), np.asarray(prm, dtype=float), True, ws)
    return ws.pt, ws.nr, ws.dpt, ws.dnr


def test_kernel_regions_agree_with_the_foundation(rng):
    cap = SphereCap((1.0, 2.0, 3.0), 13.0, (0.14, 0.0, 0.99), 60 * DEG)
    from fk_tasks import height_field_patch

    patch = BezierRegion(height_field_patch(rng, 3, 2, jitter=0.2))
    for region in (cap, patch):
        for prm in region.seed_params(3):
            p, n, dp, dn = _kernel_region(region, prm)
            p0, n0 = region.evaluate(prm)
            dp0, dn0 = region.jacobian(prm)
            np.testing.assert_allclose(p, p0[0], atol=1e-12)
            np.testing.assert_allclose(n, n0[0], atol=1e-12)
            np.testing.assert_allclose(dp, dp0[0], atol=1e-10)
            np.testing.assert_allclose(dn, dn0[0], atol=1e-10)


def test_cap_projection_keeps_parameters_in_the_cone():
    cap = SphereCap((0.0, 0.0, 0.0), 13.0, (0.14, 0.0, 0.99), 60 * DEG)
    data = RG.pack(cap)
    lo, hi = np.full(2, -np.pi), np.full(2, np.pi)
    for a, g in [(1.5, 0.2), (-2.0, 1.0), (0.1, -1.4), (3.5, 2.0)]:
        x = np.array([a, g])
        RG.project(RG.K_CAP, 0, data, x, 0, lo, hi, 1e-9)
        assert cap.domain_violation(x)[0] == 0.0
        assert np.degrees(np.arccos(cap.normals(x)[0] @ cap.axis)) == pytest.approx(60.0, abs=1e-6)


def test_a_damped_step_decreases_the_error_on_a_smooth_problem(sa_hand):
    rng = np.random.default_rng(5)
    case = build_fk_case(sa_hand, rng, fingers=("thumb", "index"), palm=False, kinds=("bezier", "point"),
                         q=np.clip(0.5 * (sa_hand.lower + sa_hand.upper), sa_hand.lower, sa_hand.upper))  # fmt: skip
    group = group_from_tasks([case.task])
    st = _State(group)
    x0, R, t = _state_from_case(case, group)
    x = x0.copy()
    x[: group.nf] += 0.05  # 3 degrees on every free angle: a smooth neighbourhood
    C, nx = len(group.contacts), group.nx
    f, J = st.residual(x, R, t)
    A, L, Js = np.zeros((6 * C, 6 * C)), np.zeros((6 * C, 6 * C)), np.zeros((6 * C, nx))
    y, dx, frozen = np.zeros(6 * C), np.zeros(nx), np.zeros(nx, dtype=bool)
    L_ = group.layout
    assert dls_dense(J, f, 6 * C, (L_.col_scale, frozen), 0.02**2, (A, L, y, dx, Js))
    f1, _ = st.residual(*st.moved(x, R, t, dx))
    assert np.linalg.norm(f1) < 0.1 * np.linalg.norm(f)
    f_half, _ = st.residual(*st.moved(x, R, t, 0.5 * dx))
    assert np.linalg.norm(f_half) < np.linalg.norm(f)


def test_a_step_solved_again_after_column_changes_is_the_step_solved_afresh():
    """refresh_column + dls_again (the active set's second solve) == dls_dense from scratch."""
    rng = np.random.default_rng(11)
    n, nx = 24, 27
    M, g, scale = rng.normal(size=(n, nx)), rng.normal(size=n), rng.uniform(0.5, 2.0, nx)
    M[:, 5][rng.random(n) < 0.7] = 0.0  # a column that only some rows see, as a finger's joint

    def scratch():
        return np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.zeros(nx), np.zeros((n, nx))

    frozen = np.zeros(nx, dtype=bool)
    out = scratch()
    assert dls_dense(M, g, n, (scale, frozen), 1e-3, out)
    frozen[3] = True  # freeze one column, turn another (changed values), release nothing
    M[:, 7] = rng.normal(size=n)
    for k in (3, 7):
        refresh_column(M, n, k, 0.0 if frozen[k] else scale[k], out[0], out[4])
    assert dls_again(g, n, (scale, frozen), out)
    fresh = scratch()
    assert dls_dense(M, g, n, (scale, frozen), 1e-3, fresh)
    np.testing.assert_allclose(out[3], fresh[3], rtol=1e-9, atol=1e-12)
    assert out[3][3] == 0.0
    np.testing.assert_allclose(out[0], fresh[0], rtol=1e-9, atol=1e-9)


# -- solutions ----------------------------------------------------------------------------
def test_random_point_problems_hold_at_their_known_configuration(sa_hand):
    pp = random_point_problems(5, sa_hand, seed=3)
    for i in range(len(pp)):
        task = pp.task(i)
        T = pp.truth["T_palm_object"][i]
        params = tuple((pp.truth["hand_params"][i, c], np.zeros(0)) for c in range(4))
        from prehension.tasks.model import Configuration

        report = evaluate(task, Configuration(pp.truth["q"][i], T, params), Tolerances(contact_mm=1e-9, normal_deg=1e-9))
        assert report.ok, report.summary()


def test_four_fingertip_point_problems_are_solved_and_re_verify(sa_hand):
    pp = random_point_problems(40, sa_hand, seed=11)
    batch = solve_local_batch(pp)
    assert len(batch) == 40
    assert batch.success.mean() >= 0.9
    assert batch.solved_after[-1] == batch.success.sum()
    assert np.all(np.diff(batch.solved_after) >= 0) and np.all(np.diff(batch.wave_seconds) >= 0)
    for rec in batch:
        task = pp.task(rec.index)
        result = rec.to_result(task)
        assert result.method == "local"
        assert result.status == rec.status
        assert result.stats["initial_poses_tried"] == rec.initial_poses_tried >= 1
        assert len(result.stats["per_pose_iterations"]) == rec.initial_poses_tried
        if not rec.success:
            assert result.message.startswith("no solution found after")
            continue
        (sol,) = result.solutions
        tol = Tolerances() if result.stats["tolerances"] == "strict" else LocalOptions().acceptance
        assert make_solution(task, sol.configuration(), tol) is not None
        _check_solution(task, sol)
    strict = [r.tolerance == "strict" for r in batch if r.success]
    assert np.mean(strict) >= 0.8  # polishing makes most answers strictly verified


@pytest.mark.parametrize("seed", range(6))
def test_fk_tasks_with_patches_caps_points_and_palm_are_solved(sa_hand, seed):
    rng = np.random.default_rng(100 + seed)
    case = build_fk_case(sa_hand, rng)
    result = solve_local(case.task, rng=seed)
    assert result.status in (Status.SOLVED, Status.GAVE_UP)
    if result.success:
        _check_solution(case.task, result.solutions[0])


def test_most_fk_tasks_are_solved(sa_hand):
    rng = np.random.default_rng(77)
    tasks = [build_fk_case(sa_hand, rng).task for _ in range(12)]
    batch = solve_local_batch(tasks)  # mixed structures: grouped inside
    assert [r.index for r in batch] == list(range(12))
    assert batch.success.sum() >= 10
    for task, result in zip(tasks, batch.results(tasks)):
        if result.success:
            _check_solution(task, result.solutions[0])


@pytest.mark.parametrize("name", ["teapot-lid-lifting", "scalpel-upholding", "guitar-tuning", "teapot-transportation", "guitar-holding"])
def test_builtin_tasks_are_solved(name):
    task = load_builtin_task(name)
    result = solve_local(task)
    assert result.success, result.message
    (sol,) = result.solutions
    assert result.stats["tolerances"] == "strict"
    assert make_solution(task, sol.configuration()) is not None  # strict default tolerances
    _check_solution(task, sol)


def test_an_unreachable_problem_gives_up_with_a_clear_message(sa_hand):
    pp = random_point_problems(1, sa_hand, seed=4)
    far = PointProblems(sa_hand, pp.hand_regions, pp.points * np.array([1.0, 1.0, 40.0]), pp.normals)
    task = far.task(0)
    options = LocalOptions(i_max=3, k_max=30)
    result = solve_local(task, options)
    assert result.status == Status.GAVE_UP and not result.success and result.solutions == ()
    assert result.message.startswith("no solution found after 3 initial poses and")
    assert result.stats["initial_poses_tried"] == 3
    assert len(result.stats["per_pose_iterations"]) == 3
    assert result.stats["iterations"] == sum(result.stats["per_pose_iterations"]) > 0


def test_couplings_are_exact_and_limits_hold_in_every_answer(sa_hand):
    pp = random_point_problems(30, sa_hand, seed=21)
    batch = solve_local_batch(pp, LocalOptions(polish=False, approximate=True))  # d_min answers too
    answers = [r for r in batch if r.joint_angles is not None]
    assert answers
    q = np.array([r.joint_angles for r in answers])
    assert coupling_violations(sa_hand, q).max() <= 1e-12
    assert limit_violations(sa_hand, q).max() == 0.0
    assert all(r.tolerance in ("strict", "d_min") for r in answers)


def test_random_initial_poses_and_the_paper_rule_also_work(sa_hand):
    pp = random_point_problems(20, sa_hand, seed=8)
    a = solve_local_batch(pp, LocalOptions(initial="random"), rng=1)
    b = solve_local_batch(pp, LocalOptions(initial="random"), rng=1)
    assert [r.iterations for r in a] == [r.iterations for r in b]  # seeded
    c = solve_local_batch(pp, LocalOptions(psi_rule="paper", repair_iterations=0, strict_retries=0))
    assert a.success.mean() >= 0.8 and c.success.mean() >= 0.8


def test_empty_batches_and_bad_input():
    pp = random_point_problems(0)
    assert len(solve_local_batch(pp)) == 0
    assert len(solve_local_batch([])) == 0
    with pytest.raises(PrehensionError, match="takes PointProblems or a list of Task"):
        solve_local_batch(["teapot"])
    with pytest.raises(PrehensionError, match="i_max must be an integer >= 1"):
        LocalOptions(i_max=0)
    with pytest.raises(PrehensionError, match="psi_rule"):
        LocalOptions(psi_rule="best")
    with pytest.raises(PrehensionError, match=r"shape \(P, 4, 3\)"):
        PointProblems(random_point_problems(1).hand, ("thumb_tip", "index_tip", "middle_tip", "ring_tip"), np.zeros((2, 3, 3)), np.zeros((2, 3, 3)))


def test_without_approximate_every_answer_is_strict_and_loose_ones_are_only_closest_misses(sa_hand):
    pp = random_point_problems(30, sa_hand, seed=21)
    loose = solve_local_batch(pp, LocalOptions(i_max=12, polish=False, approximate=True, strict_retries=0))
    strict = solve_local_batch(pp, LocalOptions(i_max=12, polish=False, strict_retries=0))  # no strict answer: every pose
    approx = [r for r in loose if r.status == Status.APPROXIMATE]
    assert approx, "unpolished iterations should leave some answers within d_min only"
    for rec in strict:
        result = rec.to_result(pp.task(rec.index))
        assert result.status in (Status.SOLVED, Status.GAVE_UP)
        if result.success:
            assert make_solution(pp.task(rec.index), result.solutions[0].configuration()) is not None
        elif rec.tolerance is None and np.isfinite(rec.max_distance_mm):  # a closest miss, reported only
            assert "the closest came within" in result.message and result.solutions == ()
    for rec in approx:
        task = pp.task(rec.index)
        result = rec.to_result(task, LocalOptions(approximate=True))
        assert result.status == Status.APPROXIMATE and not result.success
        (sol,) = result.solutions
        assert make_solution(task, sol.configuration(), LocalOptions().acceptance) is not None
        assert make_solution(task, sol.configuration()) is None  # not strict: never "solved"
        assert result.stats["acceptance"]["contact_mm"] == 1.5


def test_options_acceptance_follows_d_min():
    o = LocalOptions(d_min_mm=1.5, normal_weight_mm=25.0)
    assert o.acceptance.contact_mm == 1.5
    assert o.acceptance.normal_deg == pytest.approx(np.degrees(2 * np.arcsin(1.5 / 50.0)))
    custom = Tolerances(contact_mm=0.1, normal_deg=1.0)
    assert LocalOptions(tolerances=custom).acceptance is custom


def test_point_problem_task_round_trip(sa_hand):
    pp = random_point_problems(3, sa_hand, seed=2)
    task = pp.task(1)
    assert isinstance(task, Task) and isinstance(task.object, GraspObject)
    assert [c.hand_region for c in task.contacts] == list(pp.hand_regions)
    assert set(task.fingers) == {"thumb", "index", "middle", "ring"}
    sub = pp.subset([2, 0])
    np.testing.assert_array_equal(sub.points[1], pp.points[0])
    np.testing.assert_array_equal(sub.truth["q"][0], pp.truth["q"][2])


def test_another_hand_from_urdf_with_fingertip_caps():
    from conftest import HANDS_DIR

    path = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
    if not path.is_file():
        pytest.skip("shared/hands not present beside the checkout")
    from prehension.hands.model import HandRegion
    from prehension.hands.urdf import hand_from_urdf

    hand = hand_from_urdf(path)
    regions = {f"tip{i}": HandRegion(f.tip_link, SphereCap((0, 0, 0), 10.0, (1, 0, 0), 90 * DEG)) for i, f in enumerate(hand.fingers)}
    hand = hand.with_regions(regions)
    pp = random_point_problems(30, hand, tuple(regions), seed=1)
    batch = solve_local_batch(pp)  # no shipped sequence: PCA of random poses + the paper's lambdas
    assert batch.success.mean() >= 0.9
    for rec in batch:
        if rec.success:
            result = rec.to_result(pp.task(rec.index))
            assert result.success
            _check_solution(pp.task(rec.index), result.solutions[0])


@pytest.mark.parametrize("seed", range(3))
def test_refine_local_reaches_a_verified_configuration_near_a_known_one(sa_hand, seed):
    """The complete solver's verification: iterations from a perturbed known solution."""
    from dataclasses import replace

    from prehension.solvers.local import refine_local

    rng = np.random.default_rng(3000 + seed)
    case = build_fk_case(sa_hand, rng, palm=False)
    task = case.task
    noisy = replace(case.config, joint_angles=np.clip(
        case.config.joint_angles + np.where(task.active_mask, rng.normal(0, 0.05, sa_hand.n_dof), 0.0),
        sa_hand.lower, sa_hand.upper))  # fmt: skip
    reached = refine_local(task, [noisy, case.config])
    assert any(r is not None for r in reached.configurations)
    for config, contact_mm in zip(reached.configurations, reached.contact_mm):
        if config is not None:
            assert make_solution(task, config, Tolerances(penetration_mm=float("inf"))) is not None
            assert contact_mm < 1e-6
    assert max(reached.best()) < 1e-6
    assert refine_local(task, []).configurations == ()


# -- the repair phase and batches ---------------------------------------------------------------
def _colliding_pinch(hand, seed):
    """A thumb-index configuration in self-collision between the two moving fingers (not
    between the two fingertips), and the point-contact task its fingertip cap centres make
    (so the configuration solves it exactly)."""
    from prehension.hands.collision import collision_pairs, max_penetration
    from prehension.solvers.local.problems import random_hand_configurations

    rng = np.random.default_rng(seed)
    regions = ("thumb_tip", "index_tip")
    moving = {link for f in ("thumb", "index") for link in hand.finger(f).links}
    pairs = collision_pairs(hand)
    for _ in range(200):
        q = random_hand_configurations(hand, ("thumb", "index"), 1, rng, collision_free=False)
        pose = forward_kinematics(hand, q)
        clearance, names = capsule_clearances(hand, pose)
        worst = int(np.argmin(clearance[0]))
        tips = {hand.region(r).link for r in regions}
        if not (0.2 < -clearance[0, worst] < 3.0) or not set(names[worst]) <= moving or set(names[worst]) == tips:
            continue  # a collision of the two fingertips themselves may have no way out
        pts, nrm = [], []
        for r in regions:
            h = hand.region(r)
            p, n = h.region.evaluate(np.zeros((1, 2)))
            li = hand.link_index(h.link)
            pts.append(pose.points(li, p)[0])
            nrm.append(-pose.directions(li, n)[0])
        problem = PointProblems(hand, regions, np.array([pts]), np.array([nrm]))
        assert max_penetration(hand, pose)[0] > 0.0 and len(pairs.first)
        return q[0], problem
    raise AssertionError("no colliding pinch found")


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_colliding_answer_is_repaired_into_a_collision_free_strict_one(sa_hand, seed):
    from prehension.solvers.local.refine import _unknowns_of, run_kernel
    from prehension.tasks.model import Configuration

    q, problem = _colliding_pinch(sa_hand, seed)
    task = problem.task(0)
    start = Configuration(q, np.eye(4), ((np.zeros(2), np.zeros(0)), (np.zeros(2), np.zeros(0))))
    assert make_solution(task, start, Tolerances(penetration_mm=np.inf)) is not None  # exact, but colliding
    assert make_solution(task, start) is None
    group = group_from_tasks([task])
    out = run_kernel(group, np.zeros(1, dtype=np.int64), _unknowns_of(group, [start]), LocalOptions())
    assert out.iterations[0] == 0  # the start already holds every contact
    assert out.repair_iterations[0] > 0
    assert out.status[0] == K.STRICT, K.MESSAGES[out.status[0]]
    (config,) = refine_local(task, [start]).configurations
    assert config is not None
    sol = make_solution(task, config)  # strict default tolerances: contacts, limits, no collision
    assert sol is not None
    clearance, _ = capsule_clearances(sa_hand, forward_kinematics(sa_hand, config.joint_angles))
    assert clearance.min() >= 0.0
    unrepaired = run_kernel(group, np.zeros(1, dtype=np.int64), _unknowns_of(group, [start]), LocalOptions(repair_iterations=0))
    assert unrepaired.status[0] == K.COLLIDING


def test_every_status_code_has_a_message():
    codes = {getattr(K, n) for n in ("NOT_RUN", "STRICT", "WITHIN_DMIN", "STALLED", "K_MAX", "SINGULAR", "COLLIDING")}
    assert codes == set(K.MESSAGES) and len(codes) == 7
    assert all(isinstance(m, str) and m for m in K.MESSAGES.values())


def test_a_batch_gives_what_one_call_per_problem_gives(sa_hand):
    pp = random_point_problems(12, sa_hand, seed=31)
    batch = solve_local_batch(pp)
    for rec in batch:
        one = solve_local_batch(pp.subset([rec.index]))[0]
        assert (one.status, one.solved_with_pose, one.per_pose_iterations) == (rec.status, rec.solved_with_pose, rec.per_pose_iterations)
        if rec.joint_angles is not None:
            np.testing.assert_allclose(one.joint_angles, rec.joint_angles, atol=1e-12)
            np.testing.assert_allclose(one.T_palm_object, rec.T_palm_object, atol=1e-9)


def test_hand_arrays_are_built_once_and_not_stored_on_the_hand(sa_hand):
    from prehension.solvers.local._layout import HandArrays, hand_arrays

    a1, key1 = hand_arrays(sa_hand)
    a2, key2 = hand_arrays(sa_hand)
    assert a1 is a2 and key1 == key2
    fresh = HandArrays.from_hand(sa_hand)
    flat = lambda arrays: (*arrays.joints, *arrays[1:])  # noqa: E731
    assert all(np.array_equal(np.asarray(u), np.asarray(v)) for u, v in zip(flat(fresh), flat(a1)))
    solve_local_batch(random_point_problems(2, sa_hand, seed=1))
    assert not [k for k in vars(sa_hand) if k.startswith("_local")]


def test_compile_pending_tells_a_first_run_from_a_cached_one(tmp_path):
    import os
    import subprocess
    import sys

    from prehension.solvers.local import compile_pending, warm_up

    assert warm_up() >= 0.0
    assert compile_pending() is False  # compiled or loaded in this process
    code = "from prehension.solvers.local import compile_pending; print(compile_pending())"
    # an empty cache: a fresh install without the ahead-of-time kernels (PREHENSION_AOT=0 ignores them)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PREHENSION_AOT": "0"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.stdout.strip() == "True", out.stderr
    from prehension.kernels.aot import aot_available

    if aot_available():  # a fresh install with them compiles nothing: no COMPILING_MESSAGE
        env["PREHENSION_AOT"] = "1"
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
        assert out.stdout.strip() == "False", out.stderr


# Each kernel function compiled once: a constant argument (``0``, ``True``) is typed by numba
# as a literal and compiles a specialisation of the whole call graph below it, and a
# read-only array another; the first run pays for every one of them.  Two legitimate
# exceptions: ``copy`` and ``fill`` serve arrays of several ranks and dtypes.
_ONE_SIGNATURE = {
    "_kernel": ("run_states", "solve_state", "start", "iterate", "polish", "repair", "clearance", "_step", "_keep",
                "_restore", "_update_active_set", "_update_caps", "_turn_rims", "_turn", "_refresh",
                "_seeing_again", "_repair_step", "_seeing_step", "_seeing_solve", "_take_predicted", "_swap_rows"),
    "_workspace": ("new_workspace",),
    "_linalg": ("dls_dense", "dls_again", "refresh_column", "cholesky_solve"),
    "_model": ("contact_rows", "_hand_side", "_object_side", "_side_point", "inequality_rows", "self_collision_rows",
               "seeing_rows", "pose_hand", "initial_pose", "move"),
    "_penetration": ("object_rows", "capsule_rows", "pad_rows"),
}  # fmt: skip


def _cached_signatures(dispatcher):
    """The signatures numba's on-disk cache index holds for ``dispatcher``'s current code."""
    import hashlib

    index = dispatcher._cache._cache_file._load_index()
    code = hashlib.sha256(dispatcher.py_func.__code__.co_code).hexdigest()
    return {key[0] for key in index if key[2][0] == code}


@pytest.mark.slow  # compiles the whole kernel by JIT (1-3 min with an empty numba cache; CI shares it with test_aot's)
def test_the_kernel_compiles_each_function_for_one_signature():
    import importlib

    from prehension.objects import distance
    from prehension.kernels.jit import HAVE_NUMBA

    if not HAVE_NUMBA:
        pytest.skip("numba is not installed: nothing is compiled")
    import prehension.kernels.aot

    aot = prehension.kernels.aot.use_aot(False)  # the JIT's signatures, not the installed ahead-of-time kernels
    try:
        solve_local(load_builtin_task("teapot-lid-lifting"))  # compiles (or loads) the kernel with the object's rows
        task = load_builtin_task("teapot-service")
        task.object.distance.capsule_depth(np.zeros((1, 3)), np.ones((1, 3)), np.full(1, 5.0))
        radius = np.full(1, 5.0)
        radius.flags.writeable = False  # a read-only radius is copied: one signature for every caller
        task.object.distance.capsule_depth(np.zeros((1, 3)), np.ones((1, 3)), radius)
    finally:
        prehension.kernels.aot.use_aot(aot)
    more, missing, checked = {}, [], 0
    for module, names in _ONE_SIGNATURE.items():
        mod = importlib.import_module(f"prehension.solvers.local.{module}")
        for name in names:
            checked += 1
            sigs = _cached_signatures(getattr(mod, name))
            if not sigs:  # its file changed after a cached caller was compiled: the caller loads without it
                missing.append(f"{module}.{name}")
            if len(sigs) > 1:  # name the arguments whose types differ
                differ = [i for i, types in enumerate(zip(*sigs)) if len(set(types)) > 1]
                more[f"{module}.{name}"] = {i: sorted({str(s[i]) for s in sigs}) for i in differ}
    assert len(_cached_signatures(distance.capsule_depths)) == 1
    assert _cached_signatures(K.run_states) and len(missing) <= checked // 2, f"not in numba's cache: {missing}"
    assert not more, f"compiled for more than one signature (or a stale cache from older sources): {more}"


def test_a_seed_draws_what_the_generator_it_names_draws():
    """solve_local makes its generator only when it draws (random initial poses, or poses
    beyond the sequence); every draw is the one of np.random.default_rng(seed)."""
    from dataclasses import replace

    from prehension.hands.sa_hand import schunk_sa_hand
    from prehension.solvers.local.sequence import default_sequence

    problems = random_point_problems(6, schunk_sa_hand(), seed=11)
    tasks = [problems.task(i) for i in range(6)]
    full = default_sequence(schunk_sa_hand())
    short = replace(full, lambdas=full.lambdas[:1])  # waves 2 and 3 draw random poses
    for options, sequence in ((LocalOptions(initial="random", i_max=4), None), (LocalOptions(i_max=3, k_max=2), short)):
        lazy = solve_local_batch(tasks, options, sequence, rng=7)
        assert sequence is None or sum(r.initial_poses_tried > 1 for r in lazy) >= 1  # random poses were drawn
        eager = solve_local_batch(tasks, options, sequence, rng=np.random.default_rng(7))
        for a, b in zip(lazy, eager):
            assert a.per_pose_iterations == b.per_pose_iterations and a.solved_with_pose == b.solved_with_pose
            assert (a.joint_angles is None) == (b.joint_angles is None)
            if a.joint_angles is not None:
                np.testing.assert_array_equal(a.joint_angles, b.joint_angles)
        one = solve_local(tasks[0], options, sequence, seed=7)
        assert one.stats["per_pose_iterations"] == list(eager[0].per_pose_iterations)
    with pytest.raises(ValueError):
        solve_local(tasks[0], LocalOptions(initial="random"), seed=-1)  # refused as numpy refuses it


def test_the_least_squares_baseline_runs_algorithm_1s_outer_loop(sa_hand):
    """benchmarks/fig9.py's scipy baseline: a pose is tried only while the earlier ones failed,
    each within max_nfev evaluations, and the same seed gives the same answers."""
    from prehension.solvers.local.baseline import least_squares_batch

    problems = random_point_problems(6, sa_hand, seed=3)
    options = LocalOptions(i_max=3)
    out = least_squares_batch(problems, options, rng=1, max_nfev=40)
    tried = np.where(out["solved_with"] > 0, out["solved_with"], options.i_max)
    assert set(out["solved_with"].tolist()) <= {0, 1, 2, 3}
    np.testing.assert_array_equal(out["level"] > 0, out["solved_with"] > 0)
    assert np.all(out["nfev"] <= 40 * tried) and np.all(out["nfev"] >= tried)
    assert np.all(np.diff(out["time_after"]) >= 0.0) and out["time_after"].shape == (3,)
    again = least_squares_batch(problems, options, rng=1, max_nfev=40)
    for key in ("solved_with", "level", "nfev"):
        np.testing.assert_array_equal(out[key], again[key])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cone_params_spread_normals_over_the_cap_with_the_rim_share_on_the_rim(seed):
    """_regions.cone_params (random_point_problems' rim_fraction): every normal within the
    cone, the asked share exactly on its rim; kinds without a cone of normals get None."""
    from fk_tasks import height_field_patch
    from prehension.geometry.regions import PointRegion

    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    cap = SphereCap(rng.normal(size=3), rng.uniform(5.0, 20.0), axis / np.linalg.norm(axis), rng.uniform(20, 170) * DEG)
    params = RG.cone_params(cap, rng, 400, 0.25)
    assert params.shape == (400, 2) and np.all(cap.domain_violation(params) <= 1e-9)
    _, normals = cap.evaluate(params)
    cos_axis = normals @ cap.axis
    assert np.all(cos_axis >= np.cos(cap.half_angle) - 1e-9)
    on_rim = np.isclose(cos_axis, np.cos(cap.half_angle), atol=1e-9)
    assert 0.15 < on_rim.mean() < 0.35
    assert RG.virtual_joints(cap)
    patch = BezierRegion(height_field_patch(rng, 3, 2, jitter=0.2))
    for other in (PointRegion((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), patch):
        assert RG.cone_params(other, rng, 5, 0.5) is None and not RG.virtual_joints(other)
