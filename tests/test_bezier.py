"""Tests of prehension.geometry.bezier."""

from __future__ import annotations

from math import comb

import numpy as np
import pytest

from prehension.errors import DegeneratePatch, InvalidGeometry
from prehension.geometry.bezier import (
    BezierPatch,
    bernstein,
    bernstein_derivative,
    ensure_regular,
    subdivision_matrix,
)
from prehension.geometry.rotations import random_rotations

# Real bilinear contact regions (mm), corner order b00, b01, b10, b11.
REAL_BILINEAR = [
    ((6.493, 131.821, -15.208), (3.079, 130.322, -15.030), (3.152, 133.041, -15.373), (0.0, 131.821, -16.476)),
    ((9.14, -6.92, -1.779), (9.316, -6.92, 0.001), (9.14, -12.26, -1.779), (9.316, -12.260, 0.001)),
    ((9.316, 198.968, 0.001), (9.132, 198.968, 1.817), (9.316, 104.416, 0.001), (9.132, 104.416, 1.817)),
]


def random_patch(rng: np.random.Generator, m: int, n: int, d: int = 3) -> BezierPatch:
    return BezierPatch(rng.normal(scale=10.0, size=(m + 1, n + 1, d)))


def bilinear_formula(corners, u, v):
    p00, p01, p10, p11 = (np.asarray(c, dtype=float) for c in corners)
    u, v = u[:, None], v[:, None]
    return p00 + u * (p10 - p00) + v * (p01 - p00) + u * v * (p00 - p01 - p10 + p11)


def bicubic_bump() -> BezierPatch:
    """Curved bicubic: a height field over a 30 x 30 mm square."""
    rng = np.random.default_rng(7)
    i, j = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    z = rng.uniform(-8.0, 8.0, size=(4, 4))
    return BezierPatch(np.stack([10.0 * i, 10.0 * j, z], axis=-1))


def cylinder_patch() -> BezierPatch:
    """Bicubic approximation of a quarter cylinder of radius 20 mm, 40 mm long."""
    k = 4.0 / 3.0 * np.tan(np.pi / 8.0)
    arc = 20.0 * np.array([[1.0, 0.0], [1.0, k], [k, 1.0], [0.0, 1.0]])
    z = np.linspace(0.0, 40.0, 4)
    net = np.stack([np.column_stack([arc, np.full(4, zj)]) for zj in z], axis=1)
    return BezierPatch(net)


# ----------------------------------------------------------------------------------
# Bernstein basis
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("degree", [0, 1, 2, 3, 5, 8])
def test_bernstein_partition_of_unity_and_formula(degree):
    t = np.random.default_rng(degree).uniform(-0.5, 1.5, size=50)
    values = bernstein(degree, t)
    assert values.shape == (50, degree + 1)
    np.testing.assert_allclose(values.sum(axis=1), 1.0, atol=1e-12)
    explicit = np.array([[comb(degree, i) * x**i * (1 - x) ** (degree - i) for i in range(degree + 1)] for x in t])
    np.testing.assert_allclose(values, explicit, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("degree", [1, 2, 4, 6])
@pytest.mark.parametrize("order", [1, 2, 3])
def test_bernstein_derivative_finite_differences(degree, order):
    t = np.random.default_rng(10 * degree + order).uniform(0.0, 1.0, size=30)
    h = 1e-4
    lower = bernstein_derivative(degree, t, order - 1)
    fd = (bernstein_derivative(degree, t + h, order - 1) - bernstein_derivative(degree, t - h, order - 1)) / (2 * h)
    exact = bernstein_derivative(degree, t, order)
    assert exact.shape == lower.shape == (30, degree + 1)
    np.testing.assert_allclose(exact, fd, atol=1e-5 * max(1.0, np.abs(exact).max()))


def test_bernstein_derivative_order_zero_and_above_degree():
    t = np.linspace(0.0, 1.0, 7)
    np.testing.assert_array_equal(bernstein_derivative(3, t, 0), bernstein(3, t))
    assert np.all(bernstein_derivative(2, t, 3) == 0.0)
    assert bernstein_derivative(2, t, 3).shape == (7, 3)


def test_bernstein_rejects_bad_degree():
    with pytest.raises(InvalidGeometry, match="degree must be a non-negative integer, got -1"):
        bernstein(-1, np.zeros(3))
    with pytest.raises(InvalidGeometry, match="order"):
        bernstein_derivative(2, np.zeros(3), order=1.5)


def test_subdivision_matrix_batch_matches_single():
    a = np.array([0.0, 0.2, 0.9])
    b = np.array([1.0, 0.4, 0.1])
    batch = subdivision_matrix(3, a, b)
    assert batch.shape == (3, 4, 4)
    for k in range(3):
        np.testing.assert_allclose(batch[k], subdivision_matrix(3, a[k], b[k]), atol=1e-15)
    np.testing.assert_allclose(batch[0], np.eye(4), atol=1e-15)


# ----------------------------------------------------------------------------------
# Construction and validation
# ----------------------------------------------------------------------------------
def test_control_points_are_copied_read_only_float():
    raw = np.arange(12, dtype=np.int64).reshape(2, 2, 3)
    patch = BezierPatch(raw)
    assert patch.control_points.dtype == np.float64
    assert not patch.control_points.flags.writeable
    assert patch.degree == (1, 1) and patch.dim == 3
    with pytest.raises(ValueError):
        patch.control_points[0, 0, 0] = 5.0
    source = np.zeros((2, 3, 3))
    BezierPatch(source)
    assert source.flags.writeable


def test_equality_and_hash():
    rng = np.random.default_rng(1)
    net = rng.normal(size=(3, 2, 3))
    assert BezierPatch(net) == BezierPatch(net.copy())
    assert hash(BezierPatch(net)) == hash(BezierPatch(net.copy()))
    assert BezierPatch(net) != BezierPatch(net + 1.0)


@pytest.mark.parametrize(
    "bad, shown",
    [
        (np.zeros((2, 2)), r"got shape \(2, 2\)"),
        (np.zeros((2, 2, 3, 1)), r"got shape \(2, 2, 3, 1\)"),
        (np.zeros((0, 2, 3)), r"got shape \(0, 2, 3\)"),
        (np.zeros((2, 2, 0)), r"got shape \(2, 2, 0\)"),
    ],
)
def test_bad_shapes_raise_invalid_geometry(bad, shown):
    with pytest.raises(InvalidGeometry, match=r"control_points must have shape \(M\+1, N\+1, D\).*" + shown):
        BezierPatch(bad)


def test_non_finite_and_non_numeric_rejected():
    net = np.zeros((2, 2, 3))
    net[1, 0, 2] = np.nan
    with pytest.raises(InvalidGeometry, match=r"must be finite; got nan at index \(1, 0, 2\)"):
        BezierPatch(net)
    net[1, 0, 2] = np.inf
    with pytest.raises(InvalidGeometry, match="finite"):
        BezierPatch(net)
    with pytest.raises(InvalidGeometry, match="could not convert str"):
        BezierPatch("not a patch")
    with pytest.raises(InvalidGeometry, match="could not convert list"):
        BezierPatch([[[0, 0, 0]], [[0, 0]]])


def test_bad_parameters_rejected():
    patch = random_patch(np.random.default_rng(2), 1, 1)
    with pytest.raises(InvalidGeometry, match="finite"):
        patch.evaluate(np.nan, 0.5)
    with pytest.raises(InvalidGeometry, match=r"got shape \(2, 2\)"):
        patch.evaluate(np.zeros((2, 2)), 0.5)
    with pytest.raises(InvalidGeometry, match="derivative order must be 1 or 2"):
        patch.derivatives(0.5, 0.5, order=3)


def test_bilinear_rejects_mismatched_corners():
    with pytest.raises(InvalidGeometry, match=r"shapes \[\(3,\), \(2,\), \(3,\), \(3,\)\]"):
        BezierPatch.bilinear(np.zeros(3), np.zeros(2), np.zeros(3), np.zeros(3))


# ----------------------------------------------------------------------------------
# Evaluation and derivatives
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("corners", REAL_BILINEAR)
def test_bilinear_matches_explicit_formula(corners):
    patch = BezierPatch.bilinear(*corners)
    assert patch.degree == (1, 1)
    np.testing.assert_array_equal(patch.control_points[0, 1], corners[1])
    np.testing.assert_array_equal(patch.control_points[1, 0], corners[2])
    rng = np.random.default_rng(3)
    u, v = rng.random(100), rng.random(100)
    np.testing.assert_allclose(patch.evaluate(u, v), bilinear_formula(corners, u, v), atol=1e-10)
    for corner, (cu, cv) in zip(corners, [(0, 0), (0, 1), (1, 0), (1, 1)]):
        np.testing.assert_allclose(patch.evaluate(cu, cv)[0], corner, atol=1e-12)


def test_batch_evaluate_matches_single_evaluations():
    rng = np.random.default_rng(4)
    patch = random_patch(rng, 3, 2)
    u, v = rng.random(25), rng.random(25)
    batch = patch.evaluate(u, v)
    assert batch.shape == (25, 3)
    singles = np.concatenate([patch.evaluate(ui, vi) for ui, vi in zip(u, v)])
    np.testing.assert_allclose(batch, singles, atol=1e-12)
    assert patch.evaluate(0.3, 0.4).shape == (1, 3)
    np.testing.assert_allclose(patch.evaluate(u, 0.5), patch.evaluate(u, np.full(25, 0.5)), atol=1e-14)


def test_evaluate_extends_outside_unit_square():
    corners = REAL_BILINEAR[0]
    patch = BezierPatch.bilinear(*corners)
    u, v = np.array([-0.5, 1.7]), np.array([2.0, -1.0])
    np.testing.assert_allclose(patch.evaluate(u, v), bilinear_formula(corners, u, v), atol=1e-10)


@pytest.mark.parametrize("seed", range(6))
def test_derivatives_against_finite_differences(seed):
    rng = np.random.default_rng(100 + seed)
    m, n = int(rng.integers(1, 5)), int(rng.integers(1, 4))
    patch = random_patch(rng, m, n)
    u, v = rng.random(40), rng.random(40)
    h = 1e-5
    d = patch.derivatives(u, v)
    for field in ("p", "p_u", "p_v", "p_uu", "p_uv", "p_vv"):
        assert getattr(d, field).shape == (40, 3)
    np.testing.assert_allclose(d.p, patch.evaluate(u, v), atol=1e-12)
    np.testing.assert_allclose(d.p_u, patch.partial_u(u, v), atol=1e-12)
    np.testing.assert_allclose(d.p_v, patch.partial_v(u, v), atol=1e-12)
    fd_u = (patch.evaluate(u + h, v) - patch.evaluate(u - h, v)) / (2 * h)
    fd_v = (patch.evaluate(u, v + h) - patch.evaluate(u, v - h)) / (2 * h)
    np.testing.assert_allclose(d.p_u, fd_u, atol=1e-5)
    np.testing.assert_allclose(d.p_v, fd_v, atol=1e-5)
    fd_uu = (patch.partial_u(u + h, v) - patch.partial_u(u - h, v)) / (2 * h)
    fd_uv = (patch.partial_u(u, v + h) - patch.partial_u(u, v - h)) / (2 * h)
    fd_vu = (patch.partial_v(u + h, v) - patch.partial_v(u - h, v)) / (2 * h)
    fd_vv = (patch.partial_v(u, v + h) - patch.partial_v(u, v - h)) / (2 * h)
    np.testing.assert_allclose(d.p_uu, fd_uu, atol=1e-4)
    np.testing.assert_allclose(d.p_uv, fd_uv, atol=1e-4)
    np.testing.assert_allclose(d.p_uv, fd_vu, atol=1e-4)
    np.testing.assert_allclose(d.p_vv, fd_vv, atol=1e-4)


def test_first_order_derivatives_leave_second_order_empty():
    patch = random_patch(np.random.default_rng(5), 2, 2)
    d = patch.derivatives(0.2, 0.3, order=1)
    assert d.p_uu is None and d.p_uv is None and d.p_vv is None
    assert d.p_u.shape == (1, 3)


# ----------------------------------------------------------------------------------
# Normal patch
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("degree", [(1, 1), (1, 2), (2, 3), (3, 2), (4, 4)])
def test_normal_patch_equals_cross_product(degree):
    rng = np.random.default_rng(sum(degree))
    patch = random_patch(rng, *degree)
    normal = patch.normal_patch()
    assert normal.degree == (2 * degree[0] - 1, 2 * degree[1] - 1)
    assert normal.dim == 3
    u, v = rng.random(200), rng.random(200)
    expected = np.cross(patch.partial_u(u, v), patch.partial_v(u, v))
    np.testing.assert_allclose(normal.evaluate(u, v), expected, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("corners", REAL_BILINEAR)
def test_normal_patch_of_real_bilinear(corners):
    patch = BezierPatch.bilinear(*corners)
    u, v = np.linspace(0, 1, 11), np.linspace(1, 0, 11)
    expected = np.cross(patch.partial_u(u, v), patch.partial_v(u, v))
    np.testing.assert_allclose(patch.normal_patch().evaluate(u, v), expected, atol=1e-9)


def test_normal_patch_degree_zero_direction_raises():
    with pytest.raises(DegeneratePatch, match=r"degree \(M, N\) = \(0, 2\) is constant along u"):
        BezierPatch(np.random.default_rng(6).normal(size=(1, 3, 3))).normal_patch()
    with pytest.raises(DegeneratePatch, match=r"degree \(M, N\) = \(2, 0\) is constant along v"):
        BezierPatch(np.random.default_rng(6).normal(size=(3, 1, 3))).normal_patch()


def test_normal_patch_needs_3d():
    with pytest.raises(InvalidGeometry, match="D = 2"):
        BezierPatch(np.zeros((2, 2, 2))).normal_patch()


# ----------------------------------------------------------------------------------
# Subdivision
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [1, 3])
@pytest.mark.parametrize("degree", [(1, 1), (2, 3), (4, 2)])
def test_subdivide_reproduces_patch(dim, degree):
    rng = np.random.default_rng(20 + dim + 3 * degree[0] + degree[1])
    patch = random_patch(rng, *degree, d=dim)
    scale = np.abs(patch.control_points).max()
    s, t = rng.random(60), rng.random(60)
    for _ in range(10):
        u0, u1 = np.sort(rng.random(2))
        v0, v1 = np.sort(rng.random(2))
        sub = patch.subdivide(u0, u1, v0, v1)
        assert sub.degree == patch.degree and sub.dim == dim
        expected = patch.evaluate(u0 + s * (u1 - u0), v0 + t * (v1 - v0))
        np.testing.assert_allclose(sub.evaluate(s, t), expected, atol=1e-10 * scale)


def test_subdivide_full_box_is_identity_and_corners_interpolate():
    patch = random_patch(np.random.default_rng(8), 3, 3)
    np.testing.assert_allclose(patch.subdivide(0, 1, 0, 1).control_points, patch.control_points, atol=1e-12)
    sub = patch.subdivide(0.25, 0.5, 0.1, 0.9)
    np.testing.assert_allclose(sub.control_points[0, 0], patch.evaluate(0.25, 0.1)[0], atol=1e-12)
    np.testing.assert_allclose(sub.control_points[-1, -1], patch.evaluate(0.5, 0.9)[0], atol=1e-12)


def test_subdivide_any_real_interval():
    rng = np.random.default_rng(9)
    patch = random_patch(rng, 3, 2)
    s, t = rng.random(50), rng.random(50)
    for u0, u1, v0, v1 in [(-0.5, 1.5, 0.2, 2.0), (0.8, 0.1, 1.0, 0.0), (1.2, 1.7, -1.0, -0.2)]:
        sub = patch.subdivide(u0, u1, v0, v1)
        expected = patch.evaluate(u0 + s * (u1 - u0), v0 + t * (v1 - v0))
        np.testing.assert_allclose(sub.evaluate(s, t), expected, atol=1e-9 * np.abs(expected).max())


def test_subdivision_composes():
    rng = np.random.default_rng(10)
    patch = random_patch(rng, 3, 4, d=1)
    first = patch.subdivide(0.1, 0.9, 0.2, 0.8)
    nested = first.subdivide(0.25, 0.5, 0.5, 1.0)
    direct = patch.subdivide(0.1 + 0.25 * 0.8, 0.1 + 0.5 * 0.8, 0.2 + 0.5 * 0.6, 0.8)
    np.testing.assert_allclose(nested.control_points, direct.control_points, atol=1e-10 * np.abs(patch.control_points).max())


def test_subdivide_rejects_non_finite_bounds():
    with pytest.raises(InvalidGeometry, match="subdivision bounds must be finite"):
        random_patch(np.random.default_rng(11), 1, 1).subdivide(0.0, np.inf, 0.0, 1.0)


def test_subdivided_control_points_bound_scalar_polynomial():
    """Convex-hull property on sub-boxes (what branch-and-prune relies on)."""
    rng = np.random.default_rng(12)
    patch = random_patch(rng, 3, 3, d=1)
    sub = patch.subdivide(0.3, 0.6, 0.1, 0.4)
    s, t = rng.random(500), rng.random(500)
    values = sub.evaluate(s, t)
    lo, hi = sub.bounds()
    assert np.all(values >= lo - 1e-12) and np.all(values <= hi + 1e-12)


# ----------------------------------------------------------------------------------
# Transforms, orientation, bounds
# ----------------------------------------------------------------------------------
def test_transformed_maps_points_and_rotates_normal():
    rng = np.random.default_rng(13)
    patch = random_patch(rng, 2, 3)
    R = random_rotations(rng, 1)[0]
    t = rng.normal(scale=50.0, size=3)
    moved = patch.transformed(R, t)
    u, v = rng.random(30), rng.random(30)
    np.testing.assert_allclose(moved.evaluate(u, v), patch.evaluate(u, v) @ R.T + t, atol=1e-10)
    np.testing.assert_allclose(
        moved.normal_patch().evaluate(u, v), patch.normal_patch().evaluate(u, v) @ R.T, atol=1e-8
    )
    with pytest.raises(InvalidGeometry, match=r"got \(3,\) and \(3,\)"):
        patch.transformed(np.zeros(3), t)
    with pytest.raises(InvalidGeometry, match="D = 1"):
        random_patch(rng, 1, 1, d=1).transformed(np.eye(3), t)


def test_reversed_orientation_flips_normal():
    rng = np.random.default_rng(14)
    patch = random_patch(rng, 2, 3)
    rev = patch.reversed_orientation()
    assert rev.degree == (3, 2)
    u, v = rng.random(30), rng.random(30)
    np.testing.assert_allclose(rev.evaluate(u, v), patch.evaluate(v, u), atol=1e-12)
    np.testing.assert_allclose(rev.normal_patch().evaluate(u, v), -patch.normal_patch().evaluate(v, u), atol=1e-8)
    assert rev.reversed_orientation() == patch


def test_bounds_contain_patch():
    rng = np.random.default_rng(15)
    patch = random_patch(rng, 3, 2)
    lo, hi = patch.bounds()
    assert lo.shape == hi.shape == (3,)
    points = patch.evaluate(rng.random(1000), rng.random(1000))
    assert np.all(points >= lo - 1e-12) and np.all(points <= hi + 1e-12)
    np.testing.assert_array_equal(lo, patch.control_points.reshape(-1, 3).min(axis=0))


# ----------------------------------------------------------------------------------
# Regularity certificate
# ----------------------------------------------------------------------------------
def flat_square() -> BezierPatch:
    return BezierPatch.bilinear((0, 0, 0), (0, 20, 0), (20, 0, 0), (20, 20, 0))


@pytest.mark.parametrize(
    "patch",
    [flat_square(), bicubic_bump(), cylinder_patch()]
    + [BezierPatch.bilinear(*c) for c in REAL_BILINEAR]
    + [BezierPatch.bilinear(*c).reversed_orientation() for c in REAL_BILINEAR],
    ids=["flat", "bicubic", "cylinder"] + [f"real{i}" for i in range(3)] + [f"real{i}-reversed" for i in range(3)],
)
def test_check_nondegenerate_accepts_regular_patches(patch):
    assert patch.check_nondegenerate() is None
    assert ensure_regular(patch) is patch


def test_check_nondegenerate_accepts_rotated_regular_patch():
    rng = np.random.default_rng(16)
    patch = bicubic_bump().transformed(random_rotations(rng, 1)[0], rng.normal(size=3))
    patch.check_nondegenerate()
    patch.subdivide(0.2, 0.3, 0.7, 0.9).check_nondegenerate()


def test_rejects_triangle_with_coincident_corners():
    triangle = BezierPatch.bilinear((0, 0, 0), (0, 0, 0), (10, 0, 0), (10, 10, 0))
    with pytest.raises(DegeneratePatch, match=r"vanishes near \(u, v\) = \(0\.00, 0\.00\); a contact region needs a regular patch"):
        triangle.check_nondegenerate()
    with pytest.raises(DegeneratePatch, match="corners must not coincide"):
        ensure_regular(triangle)


def test_rejects_triangle_on_other_corner():
    triangle = BezierPatch.bilinear((0, 0, 0), (0, 10, 0), (10, 10, 0), (0, 10, 0))
    with pytest.raises(DegeneratePatch, match=r"vanishes near \(u, v\) = \(0\.00, 1\.00\)"):
        triangle.check_nondegenerate()


def folded_quad(c: float) -> BezierPatch:
    """Planar non-convex quad; its Jacobian is 1 + (c - 1)(u + v)."""
    return BezierPatch.bilinear((0, 0, 0), (0, 1, 0), (1, 0, 0), (c, c, 0))


def test_rejects_folded_net_with_normal_zero_at_a_sample():
    # Jacobian zero on u + v = 1.25, which passes through the sample (0.75, 0.5).
    patch = folded_quad(0.2)
    u, v = np.array([0.0, 1.0]), np.array([0.0, 1.0])
    assert np.prod(patch.normal_patch().evaluate(u, v)[:, 2]) < 0  # the normal flips
    with pytest.raises(DegeneratePatch, match=r"vanishes near \(u, v\) = "):
        patch.check_nondegenerate()


def test_rejects_folded_net_by_exhausting_depth():
    # Jacobian zero on u + v = 1.3, never exactly at a dyadic sample.
    with pytest.raises(DegeneratePatch, match=r"could not be shown to be non-zero .* after 6 subdivision levels"):
        folded_quad(1.0 - 1.0 / 1.3).check_nondegenerate(max_depth=6)


def u_turn_net(z_mid: float) -> np.ndarray:
    """Degree (2, 2): x(u) has control values 0, 10, 2 (out and back, x' = 0 at u = 5/9)."""
    x = np.array([0.0, 10.0, 2.0])[:, None] * np.ones(3)
    y = np.array([0.0, 5.0, 10.0])[None, :] * np.ones((3, 1))
    z = np.array([0.0, z_mid, 0.0])[:, None] + np.array([0.0, 0.0, 5.0])[None, :]
    return np.stack([x, y, z], axis=-1)


def test_rejects_curved_fold():
    # z does not depend on u, so p_u = (x'(u), 0, 0) vanishes on u = 5/9: the net folds
    # back onto itself and the normal flips sign across that line.
    patch = BezierPatch(u_turn_net(0.0))
    n = patch.normal_patch().evaluate([0.2, 0.9], [0.5, 0.5])
    assert np.dot(n[0], n[1]) < 0
    with pytest.raises(DegeneratePatch, match="could not be shown to be non-zero"):
        patch.check_nondegenerate()


def test_accepts_u_turn_that_does_not_fold():
    # Lifting the middle row makes p_u = (x', 0, z') with x' and z' never both zero:
    # the sheet turns back in 3-D but stays regular.
    BezierPatch(u_turn_net(3.0)).check_nondegenerate()


def test_rejects_degree_zero_direction():
    net = np.random.default_rng(17).normal(size=(1, 4, 3))
    with pytest.raises(DegeneratePatch, match="identically zero"):
        BezierPatch(net).check_nondegenerate()


def test_rejects_collapsed_patch():
    with pytest.raises(DegeneratePatch, match="vanishes"):
        BezierPatch(np.ones((3, 3, 3))).check_nondegenerate()
    with pytest.raises(DegeneratePatch, match="vanishes"):
        BezierPatch.bilinear((0, 0, 0), (1, 1, 1), (2, 2, 2), (3, 3, 3)).check_nondegenerate()


def test_max_depth_zero_and_validation():
    flat_square().check_nondegenerate(max_depth=0)
    with pytest.raises(InvalidGeometry, match="max_depth must be a non-negative integer"):
        flat_square().check_nondegenerate(max_depth=-1)
