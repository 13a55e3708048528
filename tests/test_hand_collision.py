"""The compiled capsule clearances against the vectorised closed form, degenerate cases included."""

from __future__ import annotations

import numpy as np

from conftest import random_angles
from prehension.hands.collision import _clearances, capsule_clearances, collision_pairs, segment_distance
from prehension.hands.kinematics import forward_kinematics


def test_compiled_clearances_equal_the_closed_form(rng):
    B, S = 200, 12
    a = rng.normal(0, 20, (B, S, 3))
    b = a + rng.normal(0, 10, (B, S, 3))
    b[:, 0] = a[:, 0]  # a point
    b[:, 1] = a[:, 1] + 2.0 * (b[:, 2] - a[:, 2])  # parallel to segment 2
    a[:, 3] = a[:, 2] + rng.normal(0, 1e-3, (B, 3))  # nearly touching ends
    radius = rng.uniform(1, 5, S)
    first, second = np.triu_indices(S, k=1)
    got = _clearances(np.ascontiguousarray(a), np.ascontiguousarray(b), radius, first, second)
    ref = segment_distance(a[:, first], b[:, first], a[:, second], b[:, second]) - radius[first] - radius[second]
    np.testing.assert_allclose(got, ref, atol=1e-9)


def test_hand_clearances_batch_equal_single_calls(sa_hand, rng):
    q = random_angles(sa_hand, rng, 7)
    batch, names = capsule_clearances(sa_hand, forward_kinematics(sa_hand, q))
    assert batch.shape == (7, len(collision_pairs(sa_hand).first)) == (7, len(names))
    for k in range(7):
        single, _ = capsule_clearances(sa_hand, forward_kinematics(sa_hand, q[k]))
        np.testing.assert_array_equal(single[0], batch[k])
