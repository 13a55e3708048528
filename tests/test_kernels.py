"""The ground floor of the compiled numerics (prehension.kernels): one segment-segment code,
one forward-kinematics loop, each checked against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.hands.kinematics import forward_kinematics, joint_tables
from prehension.kernels.chain import pose_chain
from prehension.kernels.segments import CAPSULE_EPS, MESH_EPS, closest_points, segment_params


def _sampled_distance(p0, p1, q0, q1, n=401):
    """Brute force: the smallest distance over a grid of parameters, then refined around it."""
    s = np.linspace(0.0, 1.0, n)
    P = p0 + s[:, None] * (p1 - p0)
    Q = q0 + s[:, None] * (q1 - q0)
    return np.min(np.linalg.norm(P[:, None] - Q[None], axis=-1))


@pytest.mark.parametrize("eps", [CAPSULE_EPS, MESH_EPS])
def test_segment_params_give_the_closest_points(rng, eps):
    """Over random segments, points and parallel pairs: the points at ``s, t`` are as close as
    any sampled pair (to the sampling's resolution) and their distance is the one returned."""
    for k in range(200):
        p0, p1, q0, q1 = rng.normal(0, 10, (4, 3))
        if k % 5 == 1:
            p1 = p0.copy()  # a point
        if k % 5 == 2:
            q1 = q0 + 0.5 * (p1 - p0)  # parallel
        d2, s, t = segment_params(p0, p1, q0, q1, eps)
        assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
        gap = (p0 + s * (p1 - p0)) - (q0 + t * (q1 - q0))
        assert d2 == pytest.approx(gap @ gap, rel=1e-9, abs=1e-9)
        sampled = _sampled_distance(p0, p1, q0, q1)
        assert np.sqrt(d2) <= sampled + 1e-9
        assert np.sqrt(d2) >= sampled - 0.1  # the samples are at most 40 mm / 400 apart


def test_the_degeneracy_threshold_is_each_callers():
    """A segment 1e-7 mm long is a point for capsules (CAPSULE_EPS) and a segment for a
    mesh's edges (MESH_EPS): both answers are within its length of each other."""
    p0, p1 = np.zeros(3), np.array([1e-7, 0.0, 0.0])
    q0, q1 = np.array([1e-7, 1.0, 0.0]), np.array([1e-7, 2.0, 0.0])
    _, s_capsule, _ = segment_params(p0, p1, q0, q1, CAPSULE_EPS)
    _, s_mesh, _ = segment_params(p0, p1, q0, q1, MESH_EPS)
    assert s_capsule == 0.0 and s_mesh == pytest.approx(1.0)
    pa, pb = np.empty(3), np.empty(3)
    d = closest_points(p0, p1, q0, q1, pa, pb)
    assert d == pytest.approx(np.linalg.norm(pa - pb)) and d == pytest.approx(1.0, abs=1e-7)


def test_both_forms_of_the_one_loop_place_the_links_alike(rng, sa_hand):
    """The kernel's closed form of Rot and the foundation's precomputed terms: the same
    poses to rounding (the SA hand has four universal joints, two angles each)."""
    assert any(j.kind == "universal" for j in sa_hand.joints)
    jt = joint_tables(sa_hand)
    L, n = len(sa_hand.links), sa_hand.n_dof
    for _ in range(20):
        q = rng.uniform(sa_hand.lower, sa_hand.upper)
        ref = forward_kinematics(sa_hand, q)
        R, r, axis, origin = np.empty((L, 3, 3)), np.empty((L, 3)), np.empty((n, 3)), np.empty((n, 3))
        pose_chain(q, jt, np.bool_(True), R, r, axis, origin, np.empty((3, 3)), np.empty((3, 3)), np.empty(3))
        np.testing.assert_allclose(R, ref.R_palm_link[0], atol=1e-12)
        np.testing.assert_allclose(r, ref.r_palm_link[0], atol=1e-9)
        np.testing.assert_allclose(axis, ref.axis_palm[0], atol=1e-12)
        np.testing.assert_allclose(origin, ref.origin_palm[0], atol=1e-9)


def test_the_local_kernel_reads_the_foundations_joint_tables(sa_hand):
    from prehension.solvers.local._layout import hand_arrays

    assert hand_arrays(sa_hand)[0].joints is joint_tables(sa_hand)
