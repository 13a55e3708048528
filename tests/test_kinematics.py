"""Forward kinematics and Jacobians of the hand model."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import random_angles
from prehension.errors import InvalidConfiguration, InvalidHand
from prehension.hands.kinematics import direction_jacobian, forward_kinematics, point_jacobian
from prehension.hands.model import Hand, Joint, Link

DEG = np.pi / 180


def _middle_tip_by_hand(flex, pip, dip):
    """Planar chain of the middle finger (abduction 0): flexion turns z towards +x."""
    d = lambda a: np.array([np.sin(a), 0.0, np.cos(a)])  # noqa: E731
    base = np.array([-4.3, 0.0, 150.15])
    return base + 67.8 * d(flex) + 30.0 * d(flex + pip) + 20.0 * d(flex + pip + dip)


def test_fk_matches_hand_computed_middle_finger(sa_hand):
    q = np.zeros(sa_hand.n_dof)
    angles = {"middle_mcp_flex": 30 * DEG, "middle_pip": 20 * DEG, "middle_dip": 20 * DEG}
    for name, value in angles.items():
        q[sa_hand.dof_index(name)] = value
    pose = forward_kinematics(sa_hand, q)
    tip = pose.points(sa_hand.link_index("middle_distal"), np.array([20.0, 0.0, 0.0]))[0]
    np.testing.assert_allclose(tip, _middle_tip_by_hand(30 * DEG, 20 * DEG, 20 * DEG), atol=1e-9)


def test_fk_thumb_base_rotation_by_hand(sa_hand):
    """Thumb base at 90 deg about -z: the thumb's U-joint centre (97, 6, -87) in F10 moves
    to (-3, 27.1, 0) + (87, 6, 97) and the thumb points forward and up (sin 55, 0, cos 55)...
    """
    q = np.zeros(sa_hand.n_dof)
    q[sa_hand.dof_index("thumb_base")] = 90 * DEG
    pose = forward_kinematics(sa_hand, q)
    i = sa_hand.link_index("thumb_proximal")
    np.testing.assert_allclose(pose.r_palm_link[0, i], [84.0, 33.1, 97.0], atol=1e-9)
    np.testing.assert_allclose(pose.R_palm_link[0, i][:, 0], [np.cos(55 * DEG), 0.0, np.sin(55 * DEG)], atol=1e-9)


def test_universal_angles_abduct_and_flex_as_documented(sa_hand):
    """Abduction turns the middle finger about palm x; flexion tips it towards +x."""
    q = np.zeros(sa_hand.n_dof)
    q[sa_hand.dof_index("middle_mcp_abd")] = 10 * DEG
    x_axis = forward_kinematics(sa_hand, q).R_palm_link[0, sa_hand.link_index("middle_proximal")][:, 0]
    np.testing.assert_allclose(x_axis, [0.0, -np.sin(10 * DEG), np.cos(10 * DEG)], atol=1e-12)
    q[:] = 0
    q[sa_hand.dof_index("middle_mcp_flex")] = 10 * DEG
    x_axis = forward_kinematics(sa_hand, q).R_palm_link[0, sa_hand.link_index("middle_proximal")][:, 0]
    np.testing.assert_allclose(x_axis, [np.sin(10 * DEG), 0.0, np.cos(10 * DEG)], atol=1e-12)


def test_rotations_are_proper(sa_hand, rng):
    pose = forward_kinematics(sa_hand, random_angles(sa_hand, rng, 50))
    R = pose.R_palm_link
    np.testing.assert_allclose(np.einsum("blji,bljk->blik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)


def test_batch_equals_loop(sa_hand, rng):
    q = random_angles(sa_hand, rng, 20)
    batch = forward_kinematics(sa_hand, q).T_palm_link
    loop = np.stack([forward_kinematics(sa_hand, qi).T_palm_link[0] for qi in q])
    np.testing.assert_allclose(batch, loop, atol=1e-12)


@pytest.mark.parametrize("link", ["index_distal", "thumb_distal", "ring_middle", "thumb_base", "palm"])
def test_point_and_direction_jacobians_match_finite_differences(sa_hand, rng, link):
    q = random_angles(sa_hand, rng, 5)
    li = sa_hand.link_index(link)
    p_link, n_link = np.array([20.0, 3.0, 5.0]), np.array([0.14, 0.0, 0.99])
    pose = forward_kinematics(sa_hand, q)
    Jp = point_jacobian(sa_hand, pose, li, pose.points(li, p_link))
    Jn = direction_jacobian(sa_hand, pose, li, pose.directions(li, n_link))
    h = 1e-6
    for d in range(sa_hand.n_dof):
        dq = np.zeros(sa_hand.n_dof)
        dq[d] = h
        plus, minus = forward_kinematics(sa_hand, q + dq), forward_kinematics(sa_hand, q - dq)
        fd_p = (plus.points(li, p_link) - minus.points(li, p_link)) / (2 * h)
        fd_n = (plus.directions(li, n_link) - minus.directions(li, n_link)) / (2 * h)
        np.testing.assert_allclose(Jp[:, :, d], fd_p, atol=1e-5)
        np.testing.assert_allclose(Jn[:, :, d], fd_n, atol=1e-8)


def test_bad_angles_shape_is_a_clear_error(sa_hand):
    with pytest.raises(InvalidConfiguration, match="n_dof = 17"):
        forward_kinematics(sa_hand, np.zeros(5))


def _joint(**kw):
    base = dict(
        name="j", kind="revolute", parent="palm", child="a", origin_in_parent=(0, 0, 0),
        origin_in_child=(0, 0, 0), axis_in_parent=(0, 0, 1), R_parent_child_zero=np.eye(3),
        dof_names=("j",), lower=(-1,), upper=(1,),
    )  # fmt: skip
    base.update(kw)
    return Joint(**base)


def test_bad_hands_get_named_errors():
    with pytest.raises(InvalidHand, match="kind 'prismatic' is not supported"):
        _joint(kind="prismatic")
    with pytest.raises(InvalidHand, match="lower <= upper"):
        _joint(lower=(1,), upper=(-1,))
    with pytest.raises(InvalidHand, match="must be orthogonal"):
        _joint(kind="universal", dof_names=("a", "b"), lower=(0, 0), upper=(1, 1), axis_in_child=(0, 0, 1))
    with pytest.raises(InvalidHand, match="link 'b' not found"):
        Hand("h", (Link("palm"), Link("a")), (_joint(child="b"),))
    with pytest.raises(InvalidHand, match="not connected to the palm"):
        Hand("h", (Link("palm"), Link("a"), Link("c")), (_joint(),))
    with pytest.raises(InvalidHand, match="not a rotation"):
        _joint(R_parent_child_zero=np.diag([1.0, 1.0, -1.0]))


# -- the compiled loop against the model's definition, composed in numpy -----------------
def _fk_by_definition(hand, q):
    """Link poses of one configuration composed joint by joint with numpy (the definition
    in :mod:`prehension.hands.model`): ``R_c = R_p Rot(a, q) R_zero [Rot(v, q')]``."""
    from prehension.geometry.rotations import axis_angle_to_matrix

    R = {hand.links[0].name: np.eye(3)}
    r = {hand.links[0].name: np.zeros(3)}
    for joint, off in zip(hand.joints, hand.dof_offsets):
        R_p, r_p = R[joint.parent], r[joint.parent]
        centre = R_p @ joint.origin_in_parent + r_p
        R_c = R_p @ axis_angle_to_matrix(joint.axis_in_parent, q[off]).reshape(3, 3) @ joint.R_parent_child_zero
        if joint.kind == "universal":
            R_c = R_c @ axis_angle_to_matrix(joint.axis_in_child, q[off + 1]).reshape(3, 3)
        R[joint.child], r[joint.child] = R_c, centre - R_c @ joint.origin_in_child
    return np.array([R[n] for n in hand.link_names]), np.array([r[n] for n in hand.link_names])


def _hands_to_compare(sa_hand):
    from conftest import HANDS_DIR
    from prehension.hands.files import load_hand_file

    hands = [sa_hand]
    for path in (HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf", HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf"):
        if path.is_file():
            hands.append(load_hand_file(path))
    return hands


def test_compiled_fk_equals_the_definition_to_rounding(sa_hand, rng):
    """The compiled loop (:func:`forward_kinematics`) computes the definition: every link
    pose of 200 random configurations of each hand (universal joints included: the SA
    hand's thumb) within 1e-12 of the numpy composition (rotations) and 1e-10 mm (origins:
    links hundreds of mm from the palm), i.e. rounding."""
    for hand in _hands_to_compare(sa_hand):
        q = random_angles(hand, rng, 200)
        pose = forward_kinematics(hand, q)
        for b in range(0, 200, 7):
            R, r = _fk_by_definition(hand, q[b])
            np.testing.assert_allclose(pose.R_palm_link[b], R, rtol=0, atol=1e-12)
            np.testing.assert_allclose(pose.r_palm_link[b], r, rtol=0, atol=1e-10)
        assert np.all(np.isfinite(pose.axis_palm)) and np.allclose(np.linalg.norm(pose.axis_palm, axis=-1), 1.0)
