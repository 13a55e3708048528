"""The push a grasp resists with its squeeze's forces (:mod:`prehension.sim.push`)."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.sim import PUSH_DIRECTIONS, SimOptions
from prehension.sim.push import push_margin, squeeze_forces


def test_the_largest_push_is_linear_in_the_actuator_gain(four):
    """Doubling kp doubles the squeeze's torques, its contact forces and every largest push."""
    task, grasp = four
    soft, stiff = push_margin(task, grasp, SimOptions(kp=5.0)), push_margin(task, grasp, SimOptions(kp=10.0))
    assert soft.normal.sum() > 0.0 and soft.margin > 0.0
    assert np.allclose(stiff.normal, 2.0 * soft.normal, rtol=1e-9)
    assert np.allclose(stiff.pushes, 2.0 * soft.pushes, rtol=1e-6, atol=1e-9)
    assert stiff.margin == pytest.approx(2.0 * soft.margin, rel=1e-6)


def test_no_push_beyond_what_the_cones_can_carry(four):
    """A pure force along ``d`` is carried by forces whose normal parts are the squeeze's at
    most: each largest push is at most ``sqrt(1 + mu^2)`` times the total normal force."""
    task, grasp = four
    got = push_margin(task, grasp, SimOptions())
    assert got.pushes.shape == (len(PUSH_DIRECTIONS),) and np.all(got.pushes >= 0.0)
    assert np.all(got.pushes <= np.sqrt(1 + 0.6**2) * got.normal.sum() * (1 + 1e-9))
    assert got.margin == pytest.approx(got.pushes.min() / (SimOptions().push_accel * SimOptions().mass_kg))


def test_the_squeeze_forces_balance_the_actuator_torques_in_least_squares(four):
    """``J^T f = kp (q_s - q)`` over the moving dofs, in the least-squares sense: the
    residual is orthogonal to the columns of ``J^T`` (the normal equations)."""
    from prehension.hands.kinematics import forward_kinematics, point_jacobian
    from prehension.sim.push import squeeze_for

    task, grasp = four
    options = SimOptions()
    f = squeeze_forces(task, grasp, options)
    q = np.asarray(grasp.q, float)
    tau = options.kp * (squeeze_for(task, q, grasp.T_palm_object, grasp.contacts, options)[0] - q)
    hand, pose = task.hand, forward_kinematics(task.hand, q)
    J = np.concatenate([point_jacobian(hand, pose, hand.link_index(hand.region(c.hand_region).link),
                                       np.asarray(s.hand_point, float)[None])[0] * 1e-3
                        for c, s in zip(task.contacts, grasp.contacts)])  # fmt: skip
    moving = np.asarray(task.active_mask, bool)
    residual = J[:, moving].T @ f.reshape(-1) - tau[moving]
    assert np.allclose(J[:, moving] @ residual, 0.0, atol=1e-9 * max(1.0, np.abs(tau).max()))


def test_fingers_on_one_face_cannot_resist_every_push(one_face):
    """Every force the contacts apply presses into the face, so among the six pushes one has
    a component away from the fingers that nothing resists: the margin is 0."""
    task, grasp = one_face
    got = push_margin(task, grasp, SimOptions())
    assert got.margin == 0.0 and got.normal.sum() > 0.0  # pressed, yet not held


def test_no_squeeze_no_push(four):
    task, grasp = four
    got = push_margin(task, grasp, SimOptions(squeeze_mm=0.0))
    assert np.allclose(got.normal, 0.0) and got.margin == 0.0
