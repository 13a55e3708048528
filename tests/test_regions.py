"""Contact regions: Bézier patches, sphere caps and points (prehension.geometry.regions)."""

from __future__ import annotations

import numpy as np
import pytest

from fk_tasks import height_field_patch, random_rotation
from prehension.errors import DegeneratePatch, InvalidGeometry
from prehension.geometry.bezier import BezierPatch
from prehension.geometry.regions import BezierRegion, PointRegion, SphereCap
from prehension.geometry.rotations import rotation_about

DEG = np.pi / 180.0
HALF_ANGLES_DEG = (10.0, 45.0, 90.0, 135.0, 180.0)
PATCH_DEGREES = ((1, 1), (2, 3), (3, 3))
FD_STEP = 1e-6


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_cap(rng, half_angle_deg: float) -> SphereCap:
    return SphereCap(rng.uniform(-50, 50, 3), rng.uniform(2.0, 40.0), rng.normal(size=3), half_angle_deg * DEG)


def random_bezier_region(rng, m: int, n: int) -> BezierRegion:
    """A jittered height-field patch, rigidly moved to a random place."""
    patch = height_field_patch(rng, m, n, size=rng.uniform(10, 40), bump=3.0, jitter=0.05)
    return BezierRegion(patch.transformed(random_rotation(rng), rng.uniform(-100, 100, 3)))


def random_params_in_box(region, rng, B: int) -> np.ndarray:
    lo, hi = region.param_bounds()
    return rng.uniform(lo, hi, size=(B, len(lo)))


def central_differences(region, params: np.ndarray, h: float = FD_STEP):
    """Finite-difference Jacobians of evaluate: ((B, 3, k), (B, 3, k))."""
    B, k = params.shape
    dp, dn = np.zeros((B, 3, k)), np.zeros((B, 3, k))
    for j in range(k):
        step = np.zeros(k)
        step[j] = h
        p_plus, n_plus = region.evaluate(params + step)
        p_minus, n_minus = region.evaluate(params - step)
        dp[:, :, j] = (p_plus - p_minus) / (2 * h)
        dn[:, :, j] = (n_plus - n_minus) / (2 * h)
    return dp, dn


def all_regions(rng):
    """(label, region, params (B, k)) over every kind of region the tests cover."""
    out = []
    for half in HALF_ANGLES_DEG:
        cap = random_cap(rng, half)
        out.append((f"cap{half:g}", cap, random_params_in_box(cap, rng, 16)))
    for m, n in PATCH_DEGREES:
        reg = random_bezier_region(rng, m, n)
        out.append((f"bezier{m}x{n}", reg, rng.uniform(0, 1, size=(16, 2))))
    out.append(("point", PointRegion(rng.normal(size=3), rng.normal(size=3)), np.zeros((16, 0))))
    return out


# -- Jacobians against finite differences --------------------------------------------------
@pytest.mark.parametrize("half", HALF_ANGLES_DEG)
def test_sphere_cap_jacobian_matches_finite_differences(rng, half):
    for _ in range(3):
        cap = random_cap(rng, half)
        params = random_params_in_box(cap, rng, 20)
        dp, dn = cap.jacobian(params)
        fdp, fdn = central_differences(cap, params)
        assert dp.shape == (20, 3, 2) and dn.shape == (20, 3, 2)
        np.testing.assert_allclose(dp, fdp, rtol=0, atol=1e-7 * cap.radius)
        np.testing.assert_allclose(dn, fdn, rtol=0, atol=1e-7)
        # The point moves with the normal on the sphere: dp = radius * dn.
        np.testing.assert_allclose(dp, cap.radius * dn, rtol=0, atol=1e-12 * cap.radius)


@pytest.mark.parametrize("degree", PATCH_DEGREES)
def test_bezier_jacobian_matches_finite_differences(rng, degree):
    for _ in range(3):
        reg = random_bezier_region(rng, *degree)
        params = rng.uniform(0.0, 1.0, size=(20, 2))
        dp, dn = reg.jacobian(params)
        fdp, fdn = central_differences(reg, params)
        assert dp.shape == (20, 3, 2) and dn.shape == (20, 3, 2)
        scale = np.abs(reg.patch.control_points).max()
        np.testing.assert_allclose(dp, fdp, rtol=0, atol=1e-7 * scale)
        np.testing.assert_allclose(dn, fdn, rtol=0, atol=1e-6)
        # The normal stays unit: its derivative is orthogonal to it.
        _, n = reg.evaluate(params)
        np.testing.assert_allclose(np.einsum("bi,bij->bj", n, dn), 0.0, atol=1e-12)


def test_point_region_has_no_parameters(rng):
    reg = PointRegion([1.0, 2.0, 3.0], [0.0, 0.0, 2.0])
    p, n = reg.evaluate(np.zeros((4, 0)))
    np.testing.assert_array_equal(p, np.tile([1.0, 2.0, 3.0], (4, 1)))
    np.testing.assert_array_equal(n, np.tile([0.0, 0.0, 1.0], (4, 1)))
    dp, dn = reg.jacobian(np.zeros((4, 0)))
    assert dp.shape == (4, 3, 0) and dn.shape == (4, 3, 0)
    np.testing.assert_array_equal(reg.domain_violation(np.zeros((4, 0))), np.zeros(4))
    p1, n1 = reg.evaluate(np.zeros(0))  # one parameter vector of length 0
    assert p1.shape == (1, 3) and n1.shape == (1, 3)
    assert reg.param_bounds()[0].shape == (0,) and reg.seed_params().shape == (1, 0)
    # The outputs are copies: writing to them leaves the region alone.
    p[0, 0] = 99.0
    np.testing.assert_array_equal(reg.evaluate(np.zeros(0))[0], [[1.0, 2.0, 3.0]])


# -- batch vs loop, unit normals -----------------------------------------------------------
def test_batch_equals_loop_for_every_region_kind(rng):
    for label, reg, params in all_regions(rng):
        p, n = reg.evaluate(params)
        dp, dn = reg.jacobian(params)
        viol = reg.domain_violation(params)
        assert p.shape == (16, 3) and n.shape == (16, 3) and viol.shape == (16,), label
        for b in range(len(params)):
            pb, nb = reg.evaluate(params[b])
            dpb, dnb = reg.jacobian(params[b])
            np.testing.assert_allclose(pb[0], p[b], rtol=0, atol=1e-12, err_msg=label)
            np.testing.assert_allclose(nb[0], n[b], rtol=0, atol=1e-14, err_msg=label)
            np.testing.assert_allclose(dpb[0], dp[b], rtol=0, atol=1e-12, err_msg=label)
            np.testing.assert_allclose(dnb[0], dn[b], rtol=0, atol=1e-12, err_msg=label)
            assert reg.domain_violation(params[b])[0] == pytest.approx(viol[b], abs=1e-12), label


def test_normals_have_unit_length(rng):
    for label, reg, params in all_regions(rng):
        _, n = reg.evaluate(params)
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=0, atol=1e-14, err_msg=label)
        # also outside the domain (patch extension, cap beyond its cone)
        _, n_out = reg.evaluate(3.0 * params - 1.0 if reg.n_params else params)
        np.testing.assert_allclose(np.linalg.norm(n_out, axis=1), 1.0, rtol=0, atol=1e-14, err_msg=label)


@pytest.mark.parametrize("degree", PATCH_DEGREES)
def test_bezier_outward_normal_is_normalised_pu_cross_pv(rng, degree):
    reg = random_bezier_region(rng, *degree)
    uv = rng.uniform(0, 1, size=(30, 2))
    p, n = reg.evaluate(uv)
    pu = reg.patch.partial_u(uv[:, 0], uv[:, 1])
    pv = reg.patch.partial_v(uv[:, 0], uv[:, 1])
    np.testing.assert_allclose(n, unit(np.cross(pu, pv)), rtol=0, atol=1e-13)
    np.testing.assert_allclose(p, reg.patch.evaluate(uv[:, 0], uv[:, 1]), rtol=0, atol=1e-12)
    # ...and the exact normal patch (eq. 19) points the same way.
    np.testing.assert_allclose(n, unit(reg.patch.normal_patch().evaluate(uv[:, 0], uv[:, 1])), rtol=0, atol=1e-12)
    # Swapping u and v flips the outward normal.
    flipped = BezierRegion(reg.patch.reversed_orientation())
    np.testing.assert_allclose(flipped.evaluate(uv[:, ::-1])[1], -n, rtol=0, atol=1e-13)


def test_bezier_height_field_normal_points_up_by_hand():
    """Bilinear flat square in the plane z = 5: p_u = (10, 0, 0), p_v = (0, 10, 0), n = +z."""
    reg = BezierRegion(BezierPatch.bilinear((0, 0, 5), (0, 10, 5), (10, 0, 5), (10, 10, 5)))
    p, n = reg.evaluate([[0.25, 0.5]])
    np.testing.assert_allclose(p, [[2.5, 5.0, 5.0]], atol=1e-14)
    np.testing.assert_allclose(n, [[0.0, 0.0, 1.0]], atol=1e-14)
    dp, dn = reg.jacobian([[0.25, 0.5]])
    np.testing.assert_allclose(dp[0], [[10.0, 0.0], [0.0, 10.0], [0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(dn[0], 0.0, atol=1e-14)
    assert reg.describe() == "Bézier patch 1x1"


# -- sphere caps ---------------------------------------------------------------------------
@pytest.mark.parametrize("half", HALF_ANGLES_DEG)
def test_sphere_cap_points_lie_on_the_sphere_and_follow_the_documented_rotations(rng, half):
    cap = random_cap(rng, half)
    params = random_params_in_box(cap, rng, 25)
    p, n = cap.evaluate(params)
    np.testing.assert_allclose(p, cap.center + cap.radius * n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(p - cap.center, axis=1), cap.radius, rtol=1e-13)
    e1, e2, m = cap.frame.T
    np.testing.assert_allclose(cap.frame.T @ cap.frame, np.eye(3), atol=1e-14)
    np.testing.assert_allclose(m, cap.axis, atol=1e-15)
    # n(alpha, gamma) = Rot(e1, alpha) Rot(e2, gamma) m
    for (alpha, gamma), nb in zip(params, n):
        expected = rotation_about(e1, alpha) @ rotation_about(e2, gamma) @ m
        np.testing.assert_allclose(nb, expected, rtol=0, atol=1e-14)
    np.testing.assert_allclose(cap.evaluate([0.0, 0.0])[1][0], cap.axis, atol=1e-15)


@pytest.mark.parametrize("half", HALF_ANGLES_DEG)
def test_params_for_normal_round_trips_inside_the_cone(rng, half):
    cap = random_cap(rng, half)
    lo, hi = cap.param_bounds()
    normals = unit(rng.normal(size=(400, 3)))
    angle = np.degrees(np.arccos(np.clip(normals @ cap.axis, -1, 1)))
    normals = normals[angle <= 0.98 * half]
    assert len(normals) >= 5
    params = cap.params_for_normal(5.0 * normals)  # normalised first
    assert params.shape == (len(normals), 2)
    p, n = cap.evaluate(params)
    np.testing.assert_allclose(n, normals, rtol=0, atol=1e-13)
    np.testing.assert_allclose(p, cap.center + cap.radius * normals, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(cap.domain_violation(params), 0.0)
    # The parameters of every normal inside the cone lie inside the stated box.
    assert np.all(params >= lo - 1e-12) and np.all(params <= hi + 1e-12), (
        np.degrees(params[(params < lo - 1e-12).any(axis=1) | (params > hi + 1e-12).any(axis=1)]),
        np.degrees(lo),
        np.degrees(hi),
    )
    single = cap.params_for_normal(normals[0])
    assert single.shape == (1, 2)
    np.testing.assert_allclose(single[0], params[0], atol=1e-14)


def test_sphere_cap_box_contains_the_whole_cone_beyond_90_degrees():
    """A 135-deg cap: the normal at 130 deg from the axis with alpha = 180 deg is inside
    the cone, so its parameters must be inside ``param_bounds`` (the box locate searches)."""
    cap = SphereCap([0, 0, 0], 10.0, [0, 0, 1], 135 * DEG)
    e1, e2, m = cap.frame.T
    n = -np.cos(50 * DEG) * m + np.sin(50 * DEG) * e1  # 130 deg from m
    ag = cap.params_for_normal(n)[0]
    np.testing.assert_allclose(np.abs(ag), [180 * DEG, 50 * DEG], atol=1e-12)
    assert cap.domain_violation(ag)[0] == 0.0
    lo, hi = cap.param_bounds()
    assert np.all(lo <= ag) and np.all(ag <= hi)


@pytest.mark.parametrize("half", (10.0, 45.0, 60.0, 90.0, 135.0))
def test_cap_domain_violation_is_the_excess_angle_in_degrees(rng, half):
    cap = random_cap(rng, half)
    e1, e2, m = cap.frame.T
    for excess in (0.0, 1e-3, 0.5, 2.0, 20.0):
        for gamma_sign in (0.0, 1.0):
            # with gamma = 0 the normal is at |alpha| from the axis; with alpha = 0 at |gamma|
            a = (half + excess) * DEG
            if a > np.pi / 2 and gamma_sign:
                continue
            for s in (1.0, -1.0):
                params = [0.0, s * a] if gamma_sign else [s * a, 0.0]
                viol = cap.domain_violation(params)[0]
                if half + excess <= 180.0:
                    assert viol == pytest.approx(excess, abs=1e-9), (params, viol)
    # random normals at a known angle from the axis
    for angle in rng.uniform(0, 180, 30):
        phi = rng.uniform(0, 2 * np.pi)
        n = np.cos(angle * DEG) * m + np.sin(angle * DEG) * (np.cos(phi) * e1 + np.sin(phi) * e2)
        viol = cap.domain_violation(cap.params_for_normal(n))[0]
        assert viol == pytest.approx(max(angle - half, 0.0), abs=1e-9)
    # inside the cone: exactly 0
    params = random_params_in_box(cap, rng, 200)
    inside = cap.normals(params) @ cap.axis >= np.cos(half * DEG) + 1e-12
    np.testing.assert_array_equal(cap.domain_violation(params[inside]), 0.0)
    assert np.all(cap.domain_violation(params[~inside]) >= 0.0)


def test_full_sphere_cap_has_no_violation(rng):
    cap = random_cap(rng, 180.0)
    params = rng.uniform(-4, 4, size=(100, 2))
    np.testing.assert_array_equal(cap.domain_violation(params), 0.0)
    lo, hi = cap.param_bounds()
    np.testing.assert_allclose(np.degrees(lo), [-180.0, -90.0])
    np.testing.assert_allclose(np.degrees(hi), [180.0, 90.0])


@pytest.mark.parametrize("half", HALF_ANGLES_DEG)
def test_cap_seed_params_lie_inside_the_box(rng, half):
    cap = random_cap(rng, half)
    lo, hi = cap.param_bounds()
    seeds = cap.seed_params()
    assert seeds.shape == (9, 2)
    assert np.all(seeds >= lo) and np.all(seeds <= hi)
    assert "half-angle" in cap.describe()


def test_patch_domain_violation_is_the_parameter_excess(rng):
    reg = random_bezier_region(rng, 2, 3)
    uv = np.array([[0.5, 0.5], [0.0, 1.0], [1.2, 0.5], [0.5, -0.3], [1.1, -0.4], [-0.05, 1.25], [2.0, 2.0]])
    np.testing.assert_allclose(reg.domain_violation(uv), [0.0, 0.0, 0.2, 0.3, 0.4, 0.25, 1.0], atol=1e-15)
    inside = rng.uniform(0, 1, size=(50, 2))
    np.testing.assert_array_equal(reg.domain_violation(inside), 0.0)
    lo, hi = reg.param_bounds()
    np.testing.assert_array_equal(lo, [0, 0])
    np.testing.assert_array_equal(hi, [1, 1])
    seeds = reg.seed_params()
    assert seeds.shape == (9, 2) and np.all((seeds > 0) & (seeds < 1))


# -- bad input -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(axis=[0.0, 0.0, 0.0]), "axis must be a non-zero vector"),
        (dict(radius=-1.0), "radius must be a positive number"),
        (dict(radius=0.0), "radius must be a positive number"),
        (dict(radius=float("nan")), "radius must be a positive number"),
        (dict(half_angle=190 * DEG), r"half-angle must lie in \[0, 180\] degrees, got 190"),
        (dict(half_angle=-1 * DEG), r"half-angle must lie in \[0, 180\] degrees, got -1"),
        (dict(center=[0.0, float("nan"), 0.0]), "centre must be 3 finite numbers"),
        (dict(center=[0.0, 0.0]), "centre must be 3 finite numbers"),
        (dict(axis=[0.0, float("inf"), 1.0]), "axis must be 3 finite numbers"),
    ],
)
def test_sphere_cap_rejects_bad_input(kwargs, message):
    args = dict(center=[0.0, 0.0, 0.0], radius=5.0, axis=[0.0, 0.0, 1.0], half_angle=60 * DEG)
    args.update(kwargs)
    with pytest.raises(InvalidGeometry, match=message):
        SphereCap(**args)


def test_point_region_rejects_bad_input():
    with pytest.raises(InvalidGeometry, match="contact point must be 3 finite numbers"):
        PointRegion([float("nan"), 0.0, 0.0], [0.0, 0.0, 1.0])
    with pytest.raises(InvalidGeometry, match="contact normal must be a non-zero vector"):
        PointRegion([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(InvalidGeometry, match="contact normal must be 3 finite numbers"):
        PointRegion([0.0, 0.0, 0.0], [0.0, 1.0])


def test_bezier_region_rejects_bad_input(rng):
    with pytest.raises(InvalidGeometry, match="needs 3-D control points"):
        BezierRegion(BezierPatch(rng.normal(size=(2, 2, 2))))
    with pytest.raises(DegeneratePatch, match="identically zero"):
        BezierRegion(BezierPatch(rng.normal(size=(1, 3, 3))))
    with pytest.raises(DegeneratePatch, match="vanishes"):  # all corners coincide
        BezierRegion(BezierPatch(np.zeros((2, 2, 3))))
    with pytest.raises(InvalidGeometry, match="finite"):
        BezierRegion(np.full((2, 2, 3), np.nan))
    # a raw control net is accepted and wrapped
    net = height_field_patch(rng, 2, 2).control_points
    assert isinstance(BezierRegion(net).patch, BezierPatch)


def test_regions_reject_badly_shaped_parameters(rng):
    cap = random_cap(rng, 60.0)
    reg = random_bezier_region(rng, 1, 1)
    for region in (cap, reg):
        with pytest.raises(InvalidGeometry, match=r"shape \(B, 2\)"):
            region.evaluate(np.zeros(3))
        with pytest.raises(InvalidGeometry, match=r"shape \(B, 2\)"):
            region.jacobian(np.zeros((4, 1)))
        with pytest.raises(InvalidGeometry, match=r"shape \(B, 2\)"):
            region.domain_violation(np.zeros((1, 1, 2)))
    with pytest.raises(InvalidGeometry, match=r"shape \(B, 0\)"):
        PointRegion([0, 0, 0], [0, 0, 1]).evaluate(np.zeros((2, 1)))


def test_evaluate_regions_gives_each_regions_own_evaluate_checked_bit_for_bit(rng):
    """The stacked evaluation (caps and points together, other kinds one by one) is only a
    faster way to call each region's evaluate_checked: the same bits, column by column."""
    from prehension.geometry.regions import evaluate_regions

    regions = [random_cap(rng, h) for h in HALF_ANGLES_DEG] + [random_bezier_region(rng, 2, 3)]
    regions += [PointRegion(rng.normal(size=3), rng.normal(size=3)), random_cap(rng, 30.0)]
    rng.shuffle(regions)
    for B in (1, 7):
        params = [random_params_in_box(r, rng, B) * 1.2 for r in regions]  # some outside: violations > 0
        points, normals, violation = evaluate_regions(regions, params)
        assert points.shape == normals.shape == (B, len(regions), 3) and violation.shape == (B, len(regions))
        for c, (region, prm) in enumerate(zip(regions, params)):
            p, n, v = region.evaluate_checked(prm)
            np.testing.assert_array_equal(points[:, c], p)
            np.testing.assert_array_equal(normals[:, c], n)
            np.testing.assert_array_equal(violation[:, c], v)
        assert np.any(violation > 0) and np.any(violation == 0)


def _every_kind(rng):
    return [random_bezier_region(rng, 2, 3), random_cap(rng, rng.choice(HALF_ANGLES_DEG)),
            PointRegion(rng.uniform(-50, 50, 3), rng.normal(size=3))]  # fmt: skip


@pytest.mark.parametrize("seed", range(5))
def test_transformed_regions_move_their_points_and_turn_their_normals(seed):
    rng = np.random.default_rng(seed)
    R, t = random_rotation(rng), rng.uniform(-100, 100, 3)
    for region in _every_kind(rng):
        params = region.sample_params(5)
        moved = region.transformed(R, t)
        p0, n0 = region.evaluate(params)
        # a cap's parameters are angles in a frame of its own axis: the moved cap's differ
        p1, n1 = moved.evaluate(moved.params_for_normal(n0 @ R.T) if isinstance(moved, SphereCap) else params)
        assert type(moved) is type(region)
        assert np.allclose(p1, p0 @ R.T + t, atol=1e-9) and np.allclose(n1, n0 @ R.T, atol=1e-12)
        assert np.allclose(moved.centroid(), R @ region.centroid() + t, atol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_sample_params_lie_inside_the_domain_and_a_ball_holds_its_region(seed):
    rng = np.random.default_rng(seed)
    for region in _every_kind(rng):
        params = region.sample_params(7)
        assert params.shape[1] == region.n_params and len(params) >= 1
        assert np.all(region.domain_violation(params) <= 0)
        ball = region.ball()
        assert (ball is None) == (not isinstance(region, SphereCap))
        if ball is not None:
            points, _ = region.evaluate(params)
            assert np.allclose(np.linalg.norm(points - ball[0], axis=1), ball[1])


@pytest.mark.parametrize("half", HALF_ANGLES_DEG)
def test_cap_cone_margin_is_the_cone_test_and_its_gradient_matches_finite_differences(rng, half):
    cap = random_cap(rng, half)
    for ag in random_params_in_box(cap, rng, 20):
        value, grad = cap.cone_margin(ag)
        n = cap.normals(ag[None])[0]
        assert np.isclose(value, n @ cap.axis - np.cos(cap.half_angle), atol=1e-12)
        assert (value >= -1e-12) == (cap.domain_violation(ag[None])[0] <= 1e-9)
        fd = [(cap.cone_margin(ag + h)[0] - cap.cone_margin(ag - h)[0]) / (2 * FD_STEP) for h in FD_STEP * np.eye(2)]
        assert np.allclose(grad, fd, atol=1e-6)
    assert random_bezier_region(rng, 1, 1).cone_margin(np.full(2, 0.5)) is None


@pytest.mark.parametrize("degree", [(1, 1), (2, 2), (3, 2)])
def test_restricted_patch_is_the_patch_over_its_box(rng, degree):
    """A restricted patch at ``s`` is the patch at ``lower + (upper - lower) s``: points and normals."""
    for _ in range(5):
        region = random_bezier_region(rng, *degree)
        lower = rng.uniform(0.0, 0.6, size=2)
        upper = lower + rng.uniform(0.05, 0.4, size=2)
        part = region.restricted(lower, upper)
        s = rng.uniform(0.0, 1.0, size=(20, 2))
        p_part, n_part = part.evaluate(s)
        p, n = region.evaluate(lower + (upper - lower) * s)
        np.testing.assert_allclose(p_part, p, atol=1e-9)
        np.testing.assert_allclose(n_part, n, atol=1e-9)
        assert np.array_equal(part.param_bounds()[0], np.zeros(2)) and np.array_equal(part.param_bounds()[1], np.ones(2))


def test_restricted_is_none_for_caps_and_points_and_refuses_an_empty_box(rng):
    assert random_cap(rng, 40.0).restricted(np.zeros(2), np.ones(2)) is None
    assert PointRegion(np.zeros(3), np.array([0.0, 0.0, 1.0])).restricted(np.zeros(0), np.zeros(0)) is None
    with pytest.raises(InvalidGeometry, match="lower < upper"):
        random_bezier_region(rng, 2, 2).restricted(np.array([0.5, 0.2]), np.array([0.5, 0.8]))
