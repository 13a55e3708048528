"""Fitted collision capsules enclose their link's geometry (issue 28 item 3, issue 26 item 2)."""

import math

import numpy as np
import pytest

from prehension.hands.enclosure import capsule_gaps, fit_of_points, points_distance, union_surface
from prehension.hands.model import Capsule
from prehension.hands.shapes import box_capsules, cylinder_capsule, ellipsoid_capsule, mesh_capsule


def _rounded_tip(rng, n_dome=600, n_wall=100, radius=12.0, wall=11.0):
    """A fingertip-like cloud: a dense hemisphere (z >= 0) on a sparse short tube (z in
    [-wall, 0]): almost isotropic, its centroid well above the tube's middle."""
    v = rng.normal(size=(n_dome, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    phi = rng.uniform(0, 2 * np.pi, n_wall)
    tube = np.stack([np.cos(phi), np.sin(phi), -rng.uniform(0, wall / radius, n_wall)], axis=1)
    return np.concatenate([v, tube]) * radius


@pytest.mark.parametrize("seed", range(8))
def test_near_isotropic_mesh_does_not_collapse_past_the_tip(seed):
    """The Allegro fingertip case: a principal axis of an almost isotropic cloud means
    nothing, and the old fit (a segment collapsed to the centroid, radius a percentile)
    reached 6 mm past the tip.  The fit holds every point and stays at the tip."""
    rng = np.random.default_rng(seed)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]  # any orientation, any place
    shift = rng.uniform(-50, 50, 3)
    pts = _rounded_tip(rng) @ R.T + shift
    cap = mesh_capsule(pts)
    assert capsule_gaps(pts, [cap]).max() <= 1e-9  # every vertex inside
    tip = 12.0 * R[:, 2] + shift  # the dome's pole
    reach = max(float((e - shift) @ R[:, 2]) for e in (cap.a, cap.b)) + cap.radius
    assert reach <= 12.0 + 0.6, f"the capsule reaches {reach - 12.0:.2f} mm past the tip"
    assert capsule_gaps(tip[None], [cap])[0] >= -0.6
    ideal = math.pi * 12.0**2 * 11.0 + 4 / 3 * math.pi * 12.0**3  # r 12 along the tube, segment [-11, 0]
    volume = math.pi * cap.radius**2 * np.linalg.norm(cap.b - cap.a) + 4 / 3 * math.pi * cap.radius**3
    assert volume <= 1.05 * ideal


@pytest.mark.parametrize("seed", range(6))
def test_mesh_capsule_encloses_random_clouds(seed):
    rng = np.random.default_rng(100 + seed)
    pts = rng.normal(size=(300, 3)) * rng.uniform(1, 30, 3)
    cap = mesh_capsule(pts)
    assert capsule_gaps(pts, [cap]).max() <= 1e-9


@pytest.mark.parametrize("seed", range(6))
def test_primitive_capsules_enclose_their_shape(seed):
    rng = np.random.default_rng(200 + seed)
    size = rng.uniform(3, 60, 3)
    u = rng.uniform(-1, 1, (4000, 3))
    box = u * size / 2
    assert capsule_gaps(box, box_capsules(size)).max() <= 1e-9
    r, length = rng.uniform(2, 30), rng.uniform(1, 80)
    phi = rng.uniform(0, 2 * np.pi, 4000)
    cyl = np.stack([r * np.cos(phi), r * np.sin(phi), rng.uniform(-length / 2, length / 2, 4000)], axis=1)
    assert capsule_gaps(cyl, cylinder_capsule(r, length)).max() <= 1e-9
    d = rng.normal(size=(4000, 3))
    ell = d / np.linalg.norm(d, axis=1, keepdims=True) * size
    assert capsule_gaps(ell, ellipsoid_capsule(size)).max() <= 1e-9


def test_fit_measures_miss_and_stick_out():
    """A sphere of radius 10 against a capsule of radius 12 around it: sticks out 2 mm;
    against one of radius 9: misses 1 mm."""
    rng = np.random.default_rng(7)
    d = rng.normal(size=(3000, 3))
    sphere = 10.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    dist = lambda p: np.maximum(np.linalg.norm(p, axis=1) - 10.0, 0.0)  # noqa: E731
    fat = fit_of_points([Capsule((0, 0, 0), (0, 0, 0), 12.0)], sphere, dist, "test")
    thin = fit_of_points([Capsule((0, 0, 0), (0, 0, 0), 9.0)], sphere, dist, "test")
    assert (fat.miss_mm, fat.stick_out_mm) == (0.0, pytest.approx(2.0, abs=0.01))
    assert thin.miss_mm == pytest.approx(1.0, abs=0.01) and thin.stick_out_mm == 0.0


def test_union_surface_leaves_out_what_lies_inside_another_capsule():
    caps = [Capsule((0, 0, 0), (10, 0, 0), 3.0), Capsule((5, 0, 0), (5, 0, 0), 5.0)]
    surface = union_surface(caps)
    assert capsule_gaps(surface, caps).min() >= -1e-9
    assert np.abs(capsule_gaps(surface, caps)).max() <= 1e-9


def test_points_distance_is_zero_inside_the_hull():
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    d = points_distance(cube, np.array([[0.5, 0.5, 0.5], [2.0, 0.0, 0.0]]))
    assert d[0] == 0.0 and d[1] == pytest.approx(1.0)
    assert math.isclose(points_distance(cube[:4], np.array([[3.0, 0.0, 0.0]]))[0], 3.0)  # flat set: no interior
