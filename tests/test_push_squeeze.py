"""The ``"push"`` squeeze: the balanced forces whose squeeze resists the largest push (:mod:`prehension.sim.aim`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from prehension.geometry.rotations import rotation_about
from prehension.sim import SimOptions
from prehension.sim.aim import push_squeeze
from prehension.sim.push import push_margin, squeeze_for
from prehension.sim.squeeze import inward_normals, squeeze_step
from prehension.quality.wrenches import cone_edges


def _jittered(task, grasp, rng, turn_deg: float = 15.0, dq: float = 0.05):
    """The grasp with every contact normal turned by up to ``turn_deg`` and the moving joints
    moved by up to ``dq`` rad (seeded): the program and the margin are functions of the
    contacts, angles and pose alone, verified or not."""
    contacts = []
    for c in grasp.contacts:
        axis = rng.normal(size=3)
        R = rotation_about(axis / np.linalg.norm(axis), np.radians(rng.uniform(0, turn_deg)))
        contacts.append(replace(c, object_normal=R @ np.asarray(c.object_normal, float)))
    q = np.asarray(grasp.q, float) + np.where(task.active_mask, rng.uniform(-dq, dq, task.hand.n_dof), 0.0)
    q = np.clip(q, task.hand.lower, task.hand.upper)
    return replace(grasp, joint_angles=dict(zip(task.hand.dof_names, q.tolist())), contacts=tuple(contacts))


def test_the_programs_margin_is_the_push_margin_of_its_squeeze(four):
    """Seeded draws around the four-finger grasp: the squeeze the program returns resists, by
    :func:`push_margin`'s own six linear programs, exactly the push the program promised,
    and never less than the ``"forces"`` squeeze's."""
    task, grasp = four
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(12):
        g = _jittered(task, grasp, rng)
        aimed = push_squeeze(task, g.q, g.T_palm_object, g.contacts, SimOptions())
        forces = push_margin(task, g, SimOptions(squeeze="forces")).margin
        pushed = push_margin(task, g, SimOptions(squeeze="push")).margin
        assert pushed >= forces - 1e-9
        if aimed is None:
            assert pushed == pytest.approx(forces, abs=1e-12)
            continue
        found += 1
        targets, _ = squeeze_for(task, g.q, g.T_palm_object, g.contacts, SimOptions(squeeze="push"))
        if aimed.margin >= forces + 1e-9:  # the program's squeeze is the one taken
            assert np.array_equal(targets, aimed.targets)
            assert pushed == pytest.approx(aimed.margin, rel=1e-6, abs=1e-9)
    assert found >= 6  # the draws are mostly force closure


def test_the_chosen_forces_are_balanced_in_the_cones_and_the_step_keeps_the_rules(four):
    """``f*`` (the program's ``g``) lies in the friction cones with a zero net wrench; every
    contact is aimed at most ``squeeze_mm`` in, the targets within the joint limits."""
    task, grasp = four
    options = SimOptions()
    aimed = push_squeeze(task, grasp.q, grasp.T_palm_object, grasp.contacts, options)
    assert aimed is not None and aimed.margin > 0
    f = aimed.forces
    n = inward_normals(grasp.contacts)
    normal = np.einsum("cd,cd->c", f, n)
    tangent = np.linalg.norm(f - normal[:, None] * n, axis=1)
    assert np.all(normal >= -1e-9) and np.all(tangent <= options.friction * normal + 1e-9)
    p = np.array([np.asarray(c.hand_point, float) for c in grasp.contacts])
    scale = np.abs(f).max()
    assert np.allclose(f.sum(axis=0), 0.0, atol=1e-7 * scale)
    assert np.allclose(np.cross(p, f).sum(axis=0), 0.0, atol=1e-7 * scale * np.abs(p).max())
    assert aimed.depths.max() <= options.squeeze_mm + 1e-7
    assert np.all(aimed.targets >= task.hand.lower) and np.all(aimed.targets <= task.hand.upper)
    from prehension.sim.squeeze import contact_jacobian

    moved = contact_jacobian(task, grasp.q, grasp.contacts) @ (aimed.targets - grasp.q)  # every dof, couplings as the targets have them
    assert np.allclose(np.einsum("cd,cd->c", moved.reshape(-1, 3), n), aimed.depths, atol=1e-9)  # the depths are the step's


def test_the_linearised_cones_are_inside_the_friction_cones():
    """The edges the program's forces are made of are in the (round) friction cone: their
    tangential part is ``mu`` times the normal one at most."""
    n = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    e = cone_edges(n, 0.6, 8)
    normal = np.einsum("ced,cd->ce", e, n)
    tangent = np.linalg.norm(e - normal[..., None] * n[:, None, :], axis=2)
    assert np.all(tangent <= 0.6 * normal + 1e-12)


def test_fingers_on_one_face_have_no_push_squeeze_and_keep_the_forces_one(one_face):
    """No balanced set loads contacts that all press one way: the program finds nothing, and
    the ``"push"`` squeeze is the ``"forces"`` one."""
    task, grasp = one_face
    assert push_squeeze(task, grasp.q, grasp.T_palm_object, grasp.contacts, SimOptions()) is None
    push = squeeze_for(task, grasp.q, grasp.T_palm_object, grasp.contacts, SimOptions(squeeze="push"))
    forces = squeeze_step(task, grasp.q, grasp.contacts, 10.0, "forces", 0.6)
    assert np.array_equal(push[0], forces[0]) and np.array_equal(push[1], forces[1])


def test_the_push_squeeze_scales_with_the_gain_as_the_margin_does(four):
    """Doubling kp doubles the program's margin (the feasible forces are the same)."""
    task, grasp = four
    soft = push_squeeze(task, grasp.q, grasp.T_palm_object, grasp.contacts, SimOptions(kp=5.0))
    stiff = push_squeeze(task, grasp.q, grasp.T_palm_object, grasp.contacts, SimOptions(kp=10.0))
    assert stiff.margin == pytest.approx(2.0 * soft.margin, rel=1e-6)


def test_squeeze_step_refuses_the_push_kind_with_where_to_go(four):
    task, grasp = four
    with pytest.raises(ValueError, match="squeeze_for"):
        squeeze_step(task, grasp.q, grasp.contacts, 10.0, "push")


def test_simulation_options_take_the_push_squeeze_and_name_every_kind():
    from prehension.errors import PrehensionError

    assert SimOptions(squeeze="push").squeeze == "push"
    with pytest.raises(PrehensionError, match="'push'"):
        SimOptions(squeeze="squash")


def test_check_takes_a_push_squeeze_as_good_as_the_one_found_and_no_worse(tmp_path, four):
    """A stored push squeeze re-derives when its targets are the program's, or another step
    as good: here the program's plus a joint motion that moves no contact (the null space
    of the contacts' Jacobian over the free dofs, couplings kept), same depths, same margin.
    The forces squeeze's targets (a smaller margin), a coupling broken and stated depths
    that are not the step's are refused."""
    from prehension.sim.push import as_good_a_push_squeeze
    from prehension.sim.squeeze import _problem, _targets

    task, grasp = four
    q, T, contacts, options = np.asarray(grasp.q, float), grasp.T_palm_object, grasp.contacts, SimOptions()
    targets, depths = squeeze_for(task, q, T, contacts, options)
    assert as_good_a_push_squeeze(task, q, T, contacts, options, targets, depths)
    J, _, free, _ = _problem(task, q, contacts, 10.0, None)
    null = np.linalg.svd(J[:, free])[2][-1]  # more free dofs than contact rows: a motion that moves no contact
    assert np.allclose(J[:, free] @ null, 0.0, atol=1e-9)
    other = _targets(task.hand, targets, free, 0.02 * null)
    assert not np.allclose(other, targets, atol=1e-6)
    assert np.all(other >= task.hand.lower) and np.all(other <= task.hand.upper)
    assert as_good_a_push_squeeze(task, q, T, contacts, options, other, depths)
    forces, forces_depths = squeeze_step(task, q, contacts, 10.0, "forces", 0.6)
    assert not as_good_a_push_squeeze(task, q, T, contacts, options, forces, forces_depths)
    uncoupled = targets.copy()  # a coupled dof that does not follow its source
    uncoupled[task.hand.dof_index(task.hand.couplings[0].dof)] -= 0.05
    assert not as_good_a_push_squeeze(task, q, T, contacts, options, uncoupled, depths)
    assert not as_good_a_push_squeeze(task, q, T, contacts, options, targets, depths + 0.5)
