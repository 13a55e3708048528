"""The compiled capsule clearances against the vectorised closed form, degenerate cases included."""

from __future__ import annotations

import numpy as np

from conftest import random_angles
from prehension.hands.collision import _clearances, capsule_clearances, collision_pairs, segment_distance
from prehension.hands.kinematics import forward_kinematics


def _reference_segment_distance(p0, p1, q0, q1):
    """An independent oracle: Ericson 5.1.9 in numpy, vectorised over the leading axes."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = np.sum(d1 * d1, axis=-1), np.sum(d2 * d2, axis=-1)
    f, c, b = np.sum(d2 * r, axis=-1), np.sum(d1 * r, axis=-1), np.sum(d1 * d2, axis=-1)
    denom, tiny = a * e - b * b, 1e-12
    safe = lambda x: np.where(x > tiny, x, 1.0)  # noqa: E731
    s = np.where(denom > tiny * np.maximum(a * e, tiny), np.clip((b * f - c * e) / safe(denom), 0, 1), 0.0)
    s = np.where(e > tiny, s, np.clip(-c / safe(a), 0.0, 1.0))  # q is a point
    s = np.where(a > tiny, s, 0.0)  # p is a point
    t = np.where(e > tiny, (b * s + f) / safe(e), 0.0)
    t_c = np.clip(t, 0.0, 1.0)
    s = np.where((t != t_c) & (a > tiny), np.clip((b * t_c - c) / safe(a), 0.0, 1.0), s)
    return np.linalg.norm((p0 + d1 * s[..., None]) - (q0 + d2 * t_c[..., None]), axis=-1)


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
    ref = _reference_segment_distance(a[:, first], b[:, first], a[:, second], b[:, second]) - radius[first] - radius[second]
    np.testing.assert_allclose(got, ref, atol=1e-9)
    vectorised = segment_distance(a[:, first], b[:, first], a[:, second], b[:, second]) - radius[first] - radius[second]
    np.testing.assert_allclose(vectorised, ref, atol=1e-9)
    assert segment_distance(a[0, 0], b[0, 0], a[:, 1], b[:, 1]).shape == (B,)  # broadcast over the leading axes


def test_hand_clearances_batch_equal_single_calls(sa_hand, rng):
    q = random_angles(sa_hand, rng, 7)
    batch, names = capsule_clearances(sa_hand, forward_kinematics(sa_hand, q))
    assert batch.shape == (7, len(collision_pairs(sa_hand).first)) == (7, len(names))
    for k in range(7):
        single, _ = capsule_clearances(sa_hand, forward_kinematics(sa_hand, q[k]))
        np.testing.assert_array_equal(single[0], batch[k])
