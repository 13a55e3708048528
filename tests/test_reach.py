"""Span bounds of hands (prehension.hands.reach): valid upper bounds, within tolerance."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from conftest import HANDS_DIR, random_angles
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.reach import chain_joints, lever_arms_mm, max_point_distance, span_bound_mm

TIP_POINT_MM = np.array([3.0, -2.0, 10.0])  # a point fixed in each tip link, off its axes


def _tip_links(hand):
    return [f.links[-1] for f in hand.fingers]


def _sampled_distances(hand, link_a, link_b, q):
    pose = forward_kinematics(hand, q)
    pa = pose.points(hand.link_index(link_a), np.broadcast_to(TIP_POINT_MM, (len(q), 3)))
    if link_b is None:
        return np.linalg.norm(pa, axis=1)
    pb = pose.points(hand.link_index(link_b), np.broadcast_to(TIP_POINT_MM, (len(q), 3)))
    return np.linalg.norm(pa - pb, axis=1)


def test_lever_arms_bound_the_distance_from_every_joint_centre(sa_hand, rng):
    q = random_angles(sa_hand, rng, 2000)
    pose = forward_kinematics(sa_hand, q)
    for link in _tip_links(sa_hand):
        chain = chain_joints(sa_hand, link)
        p = pose.points(sa_hand.link_index(link), np.broadcast_to(TIP_POINT_MM, (len(q), 3)))
        for joint, arm in zip(chain, lever_arms_mm(chain, TIP_POINT_MM)):
            dof = sa_hand.dof_offsets[sa_hand.joints.index(joint)]
            dist = np.linalg.norm(p - pose.origin_palm[:, dof], axis=1)
            assert dist.max() <= arm + 1e-9


def test_span_bound_holds_over_sampled_configurations_and_is_tight(sa_hand, rng):
    q = random_angles(sa_hand, rng, 20000)
    tips = _tip_links(sa_hand)
    for link_a, link_b in list(itertools.combinations(tips, 2))[:3] + [(tips[0], None)]:
        bound = max_point_distance(sa_hand, link_a, TIP_POINT_MM, link_b, None if link_b is None else TIP_POINT_MM,
                                   tol_mm=1.0)  # fmt: skip
        sampled = _sampled_distances(sa_hand, link_a, link_b, q).max()
        assert sampled <= bound.upper_mm
        assert bound.lower_mm <= bound.upper_mm <= bound.lower_mm + 1.0 + 1e-6
        assert sampled <= bound.lower_mm + 1.0 + 1e-6  # the search found (nearly) the maximum


def test_exhausted_budget_still_gives_a_valid_bound(sa_hand, rng):
    tips = _tip_links(sa_hand)
    tight = max_point_distance(sa_hand, tips[0], TIP_POINT_MM, tips[-1], TIP_POINT_MM, tol_mm=1.0)
    loose = max_point_distance(sa_hand, tips[0], TIP_POINT_MM, tips[-1], TIP_POINT_MM, tol_mm=1.0, max_boxes=300)
    assert loose.boxes <= 300 + 512
    assert loose.upper_mm >= tight.lower_mm
    assert _sampled_distances(sa_hand, tips[0], tips[-1], random_angles(sa_hand, rng, 5000)).max() <= loose.upper_mm


def test_points_on_one_link_and_the_palm_alone(sa_hand):
    tip = _tip_links(sa_hand)[0]
    same = max_point_distance(sa_hand, tip, [0.0, 0.0, 0.0], tip, [3.0, 4.0, 0.0])
    assert same.upper_mm == pytest.approx(5.0, abs=1e-6)  # rigid: no angle changes it
    palm = max_point_distance(sa_hand, sa_hand.palm, [0.0, 0.0, 12.0])
    assert palm.upper_mm == pytest.approx(12.0, abs=1e-6)


def test_span_bound_is_remembered(sa_hand):
    tips = _tip_links(sa_hand)
    first = span_bound_mm(sa_hand, tips[1], TIP_POINT_MM, tips[2], TIP_POINT_MM)
    again = span_bound_mm(sa_hand, tips[1], TIP_POINT_MM, tips[2], TIP_POINT_MM)
    assert first == again


@pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")
def test_span_bound_on_an_imported_hand_with_couplings(rng):
    from prehension.hands.urdf import load_urdf_hand

    hand, _ = load_urdf_hand(HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf")
    assert hand.couplings  # the SVH's mimic joints
    tips = _tip_links(hand)
    q = random_angles(hand, rng, 20000)
    bound = max_point_distance(hand, tips[0], TIP_POINT_MM, tips[1], TIP_POINT_MM, tol_mm=2.0)
    assert _sampled_distances(hand, tips[0], tips[1], q).max() <= bound.upper_mm
