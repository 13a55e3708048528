"""The balanced squeeze: contact forces in the friction cones with zero net wrench."""

from __future__ import annotations


import numpy as np
import pytest

from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, contact_quality
from prehension.sim import SimOptions
from prehension.sim.squeeze import balanced_normal_forces, squeeze_depths, squeeze_step, squeeze_targets


def _net(points, forces):
    return np.r_[forces.sum(axis=0), np.cross(points, forces).sum(axis=0)]


def test_force_closure_contacts_get_forces_that_cancel():
    """Seeded random contacts on a sphere: whenever the grasp is force closure (mu 0.6, 8
    edges), the forces found lie in the cones, every contact presses, and they cancel."""
    rng = np.random.default_rng(5)
    closed = 0
    for _ in range(60):
        C = int(rng.integers(3, 6))
        inward = rng.normal(size=(C, 3))
        inward /= np.linalg.norm(inward, axis=1, keepdims=True)
        points = -40.0 * inward + rng.normal(size=3) * 5.0
        fc = contact_quality(points, inward, points.mean(axis=0) - 0.0, 40.0, QualityOptions()).force_closure
        got = balanced_normal_forces(points, inward, 0.6)
        assert np.all(got.normal >= 1 - 1e-9) and got.normal.min() == pytest.approx(1.0)
        normal = np.einsum("cd,cd->c", got.forces, inward)
        assert np.allclose(normal, got.normal, rtol=1e-6)
        tangent = np.linalg.norm(got.forces - normal[:, None] * inward, axis=1)
        assert np.all(tangent <= 0.6 * normal + 1e-6)  # inside the (linearised) cone
        if fc:
            closed += 1
            assert got.residual == 0.0
            assert np.allclose(_net(points, got.forces), 0.0, atol=1e-5 * 40 * got.normal.sum())
    assert closed >= 10  # the draw tests something


def test_one_face_contacts_cannot_balance(one_face):
    task, grasp = one_face
    points = np.array([c.hand_point for c in grasp.contacts])
    inward = -np.array([c.object_normal for c in grasp.contacts])
    assert balanced_normal_forces(points, inward, 0.6).residual > 0.1


def test_the_balanced_squeeze_presses_the_thumb_as_hard_as_three_fingers(four):
    """Three fingertips on one face of the box, the thumb opposite: the thumb's depth is
    the largest (the stated squeeze) and the three fingers' depths add up to it."""
    task, grasp = four
    depths = squeeze_depths(grasp.contacts, 10.0, "balanced")
    thumb = int(np.argmax(depths))
    assert depths[thumb] == pytest.approx(10.0)
    assert np.delete(depths, thumb).sum() == pytest.approx(10.0, rel=1e-4)
    assert np.allclose(squeeze_depths(grasp.contacts, 10.0, "uniform"), 10.0)


def test_an_unknown_squeeze_kind_is_refused_by_name():
    with pytest.raises(PrehensionError, match="squeeze must be 'forces', 'push', 'balanced' or 'uniform'"):
        SimOptions(squeeze="hard")
    assert SimOptions().squeeze == "push"


def _static_imbalance(task, grasp, kind) -> tuple[float, np.ndarray]:
    """The contact forces that balance a squeeze's actuator torques (``J^T f = kp dq``, least
    squares over the moving dofs), their net wrench relative to their size (torques over
    the contacts' largest lever), and their normal parts."""
    from prehension.hands.kinematics import forward_kinematics, point_jacobian

    q = np.asarray(grasp.q, float)
    q_s = squeeze_step(task, q, grasp.contacts, 10.0, kind)[0]
    hand, pose = task.hand, forward_kinematics(task.hand, q)
    J = np.concatenate([point_jacobian(hand, pose, hand.link_index(hand.region(c.hand_region).link),
                                       np.asarray(s.hand_point, float)[None])[0]
                        for c, s in zip(task.contacts, grasp.contacts)])  # fmt: skip
    moving = np.asarray(task.active_mask, bool)
    f = np.linalg.lstsq(J[:, moving].T, (q_s - q)[moving], rcond=None)[0].reshape(-1, 3)
    points = np.array([c.hand_point for c in grasp.contacts])
    arm = points - points.mean(axis=0)
    lever = np.linalg.norm(arm, axis=1).max()
    net = _net(arm, f)
    size = np.linalg.norm(f, axis=1).sum()
    inward = -np.array([c.object_normal for c in grasp.contacts])
    return float(np.linalg.norm(net[:3]) / size + np.linalg.norm(net[3:]) / (lever * size)), np.einsum("cd,cd->c", f, inward)


def test_the_forces_squeeze_presses_with_forces_that_cancel(four):
    """The ``"forces"`` step on the force-closure box grasp: the deepest contact is aimed the
    stated depth; the contact forces that balance its actuator torques all press, and their
    net wrench is a small part of them -- far smaller than the balanced-depth squeeze's,
    whose depths ignore how hard each finger presses per mm."""
    task, grasp = four
    q_s, depths = squeeze_step(task, grasp.q, grasp.contacts, 10.0, "forces")
    assert depths.max() == pytest.approx(10.0) and np.all(depths > 0)
    forces, normal = _static_imbalance(task, grasp, "forces")
    balanced, _ = _static_imbalance(task, grasp, "balanced")
    assert np.all(normal > 0)
    assert forces < 0.25 and forces < 0.5 * balanced, (forces, balanced)  # 0.16 and 0.80 (the couplings: not 0)


def test_every_kind_gives_its_depths_and_targets(four):
    """``squeeze_step`` of the balanced and uniform kinds is ``squeeze_depths`` then
    ``squeeze_targets`` (the stored squeeze of earlier result files re-derives the same)."""
    task, grasp = four
    for kind in ("balanced", "uniform"):
        q_s, depths = squeeze_step(task, grasp.q, grasp.contacts, 10.0, kind)
        assert np.array_equal(depths, squeeze_depths(grasp.contacts, 10.0, kind))
        assert np.array_equal(q_s, squeeze_targets(task, grasp.q, grasp.contacts, 10.0, depths))
    with pytest.raises(ValueError, match="squeeze_step"):
        squeeze_depths(grasp.contacts, 10.0, "forces")


@pytest.mark.parametrize("seed", range(6))
def test_the_forces_squeeze_on_forward_built_grasps(sa_hand, seed):
    """Seeded forward-built grasps (every region kind, 2-5 contacts, mostly not force
    closure): the forces step keeps the joint limits and the couplings, aims its deepest
    contact the stated 10 mm, and the contact forces that balance its actuator torques are
    less unbalanced than the balanced-depth squeeze's (measured on seeds 300-311: 12 of 12)."""
    from fk_tasks import build_fk_case

    from prehension.results import make_solution

    rng = np.random.default_rng(300 + seed)
    solution = None
    while solution is None:  # a draw whose fingers collide is no grasp: draw again
        case = build_fk_case(sa_hand, rng)
        solution = make_solution(case.task, case.config)
    task, q = case.task, np.asarray(solution.q, float)
    q_s, depths = squeeze_step(task, q, solution.contacts, 10.0, "forces")
    assert np.all(q_s >= sa_hand.lower - 1e-12) and np.all(q_s <= sa_hand.upper + 1e-12)
    for c in sa_hand.couplings:
        i, s = sa_hand.dof_index(c.dof), sa_hand.dof_index(c.source)
        if sa_hand.lower[i] < q_s[i] < sa_hand.upper[i]:  # not clipped
            assert q_s[i] - q[i] == pytest.approx(c.ratio * (q_s[s] - q[s]), abs=1e-12)
    assert depths.max() == pytest.approx(10.0)
    assert np.all(q_s[~np.asarray(task.active_mask, bool)] == q[~np.asarray(task.active_mask, bool)])
    assert _static_imbalance(task, solution, "forces")[0] < _static_imbalance(task, solution, "balanced")[0]
