"""The balanced squeeze: contact forces in the friction cones with zero net wrench."""

from __future__ import annotations


import numpy as np
import pytest

from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, contact_quality
from prehension.sim import SimOptions
from prehension.sim.squeeze import balanced_normal_forces, squeeze_depths


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
    with pytest.raises(PrehensionError, match="squeeze must be 'balanced' or 'uniform'"):
        SimOptions(squeeze="hard")
