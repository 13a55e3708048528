"""Tests of prehension.geometry.rotations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from prehension.errors import InvalidGeometry
from prehension.geometry.rotations import (
    axis_angle_to_matrix,
    invert_transform,
    is_rotation,
    make_transform,
    matrix_to_axis_angle,
    orthonormal_frame,
    random_rotations,
    rotation_about,
    signed_angle,
    skew,
)


def random_unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_skew_is_cross_product():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(20, 3)), rng.normal(size=(20, 3))
    K = skew(a)
    assert K.shape == (20, 3, 3)
    np.testing.assert_allclose(np.einsum("bij,bj->bi", K, b), np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(K, -np.swapaxes(K, 1, 2), atol=0)
    assert skew(np.array([1.0, 2.0, 3.0])).shape == (3, 3)


def test_rodrigues_matches_scipy():
    rng = np.random.default_rng(1)
    axis = random_unit(rng, 50)
    angle = rng.uniform(-2 * np.pi, 2 * np.pi, size=50)
    R = axis_angle_to_matrix(axis, angle)
    assert R.shape == (50, 3, 3)
    expected = Rotation.from_rotvec(axis * angle[:, None]).as_matrix()
    np.testing.assert_allclose(R, expected, atol=1e-12)
    assert np.all(is_rotation(R))


def test_axis_angle_broadcasting_and_normalisation():
    angle = np.array([0.0, 0.5, 1.0])
    R = axis_angle_to_matrix(np.array([0.0, 0.0, 2.0]), angle)
    assert R.shape == (3, 3, 3)
    np.testing.assert_allclose(R[1], Rotation.from_rotvec([0, 0, 0.5]).as_matrix(), atol=1e-12)
    assert axis_angle_to_matrix([1.0, 0.0, 0.0], 0.3).shape == (1, 3, 3)
    with pytest.raises(InvalidGeometry, match="axis must be non-zero"):
        axis_angle_to_matrix(np.zeros(3), 1.0)
    with pytest.raises(InvalidGeometry, match="different batch sizes"):
        axis_angle_to_matrix(np.eye(3), np.zeros(2))


def test_right_handed():
    R = rotation_about(np.array([0.0, 0.0, 1.0]), np.pi / 2)
    assert R.shape == (3, 3)
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    with pytest.raises(InvalidGeometry, match="scalar angle"):
        rotation_about(np.array([0.0, 0.0, 1.0]), np.array([1.0, 2.0]))


def test_matrix_to_axis_angle_round_trip():
    rng = np.random.default_rng(2)
    axis = random_unit(rng, 40)
    angle = rng.uniform(0.0, np.pi, size=40)
    angle[:3] = [0.0, np.pi, np.pi - 1e-9]
    R = axis_angle_to_matrix(axis, angle)
    axis2, angle2 = matrix_to_axis_angle(R)
    assert axis2.shape == (40, 3) and angle2.shape == (40,)
    np.testing.assert_allclose(angle2, angle, atol=1e-7)
    np.testing.assert_allclose(axis_angle_to_matrix(axis2, angle2), R, atol=1e-9)
    np.testing.assert_allclose(axis2[0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(np.linalg.norm(axis2, axis=1), 1.0, atol=1e-12)
    with pytest.raises(InvalidGeometry, match=r"R\[0\] is not a rotation"):
        matrix_to_axis_angle(2.0 * np.eye(3))


def test_random_rotations_are_rotations_and_roughly_uniform():
    rng = np.random.default_rng(3)
    R = random_rotations(rng, 4000)
    assert R.shape == (4000, 3, 3)
    assert np.all(is_rotation(R))
    # Haar measure: E[R] = 0 and the rotation angle has density (1 - cos a) / pi.
    np.testing.assert_allclose(R.mean(axis=0), 0.0, atol=0.05)
    _, angle = matrix_to_axis_angle(R)
    assert abs(np.mean(angle) - (np.pi / 2 + 2 / np.pi)) < 0.05
    np.testing.assert_array_equal(random_rotations(np.random.default_rng(5), 3), random_rotations(np.random.default_rng(5), 3))
    assert random_rotations(rng, 0).shape == (0, 3, 3)


def test_is_rotation():
    assert is_rotation(np.eye(3)) is True
    assert is_rotation(np.diag([1.0, 1.0, -1.0])) is False
    assert is_rotation(2 * np.eye(3)) is False
    assert is_rotation(np.full((3, 3), np.nan)) is False
    batch = np.stack([np.eye(3), np.diag([-1.0, -1.0, 1.0]), np.diag([-1.0, 1.0, 1.0])])
    np.testing.assert_array_equal(is_rotation(batch), [True, True, False])
    assert is_rotation(np.eye(3) + 1e-7, atol=1e-6) is True
    with pytest.raises(InvalidGeometry, match=r"got shape \(3,\)"):
        is_rotation(np.zeros(3))


def test_orthonormal_frame():
    rng = np.random.default_rng(4)
    for z in list(random_unit(rng, 20)) + [np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -3.0]), np.array([1.0, 1.0, 0.0])]:
        F = orthonormal_frame(z)
        assert F.shape == (3, 3)
        assert is_rotation(F)
        np.testing.assert_allclose(F[:, 2], z / np.linalg.norm(z), atol=1e-12)
        np.testing.assert_array_equal(orthonormal_frame(z), F)
    np.testing.assert_allclose(orthonormal_frame(np.array([0.0, 0.0, 1.0])), np.eye(3), atol=1e-15)
    batch = orthonormal_frame(random_unit(rng, 5))
    assert batch.shape == (5, 3, 3) and np.all(is_rotation(batch))


def test_signed_angle_round_trip():
    rng = np.random.default_rng(5)
    axis = random_unit(rng, 100)
    a = rng.normal(size=(100, 3))
    angle = rng.uniform(-np.pi + 1e-6, np.pi, size=100)
    b = np.einsum("bij,bj->bi", axis_angle_to_matrix(axis, angle), a)
    b = 2.5 * b + 3.0 * axis  # length and axial component do not matter
    result = signed_angle(a, b, axis)
    assert result.shape == (100,)
    np.testing.assert_allclose(result, angle, atol=1e-9)
    np.testing.assert_allclose(signed_angle(b, a, axis), -angle, atol=1e-9)
    np.testing.assert_allclose(signed_angle(a, b, -axis), -angle, atol=1e-9)


def test_signed_angle_simple_cases():
    x, y, z = np.eye(3)
    assert signed_angle(x, y, z) == pytest.approx(np.pi / 2)
    assert signed_angle(y, x, z) == pytest.approx(-np.pi / 2)
    assert signed_angle(x, -x, z) == pytest.approx(np.pi)


def test_transforms_round_trip():
    rng = np.random.default_rng(6)
    R = random_rotations(rng, 10)
    t = rng.normal(scale=100.0, size=(10, 3))
    T = make_transform(R, t)
    assert T.shape == (10, 4, 4)
    np.testing.assert_array_equal(T[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (10, 1)))
    Tinv = invert_transform(T)
    np.testing.assert_allclose(Tinv @ T, np.broadcast_to(np.eye(4), (10, 4, 4)), atol=1e-12)
    np.testing.assert_allclose(Tinv, np.linalg.inv(T), atol=1e-12)
    x = rng.normal(size=3)
    np.testing.assert_allclose((T[0] @ np.append(x, 1.0))[:3], R[0] @ x + t[0], atol=1e-12)
    single = make_transform(np.eye(3), np.array([1.0, 2.0, 3.0]))
    assert single.shape == (4, 4)
    np.testing.assert_allclose(invert_transform(single)[:3, 3], [-1.0, -2.0, -3.0])
    with pytest.raises(InvalidGeometry, match=r"T must have shape \(4, 4\)"):
        invert_transform(np.eye(3))


def test_angle_between_is_accurate_near_zero_and_pi():
    from prehension.geometry.rotations import angle_between

    a = np.array([1.0, 0.0, 0.0])
    for tiny in (1e-12, 1e-9, 1e-6):
        b = np.array([np.cos(tiny), np.sin(tiny), 0.0])
        assert angle_between(a, b) == pytest.approx(tiny, rel=1e-6)
        assert angle_between(a, -b) == pytest.approx(np.pi - tiny, abs=1e-15)
    batch = angle_between(np.tile(a, (3, 1)), np.eye(3))
    np.testing.assert_allclose(batch, [0.0, np.pi / 2, np.pi / 2], atol=1e-15)
