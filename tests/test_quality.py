"""Grasp quality: wrench sets, force closure, Ferrari-Canny epsilon, volume, the object's solid."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from prehension.errors import InvalidObject, PrehensionError
from prehension.geometry.regions import PointRegion
from prehension.objects.meshes import Box, Sphere, Torus
from prehension.objects.model import GraspObject
from prehension.quality import (
    QualityOptions, contact_quality, force_closure, grasp_quality, hull_measures, mass_properties, object_reference,
    object_solid, primitive_wrenches,
)  # fmt: skip

ORIGIN = np.zeros(3)


def pinch(a=20.0):
    """Two antipodal contacts on a sphere of radius ``a`` (object frame), pushing inwards."""
    return np.array([[a, 0, 0], [-a, 0, 0]]), np.array([[-1.0, 0, 0], [1.0, 0, 0]])


def equator(n, radius=30.0, z=0.0):
    """``n`` contacts evenly spaced on a circle of a sphere of ``radius`` at height ``z``, normals to the centre."""
    ang = 2 * np.pi * np.arange(n) / n
    r = np.sqrt(radius**2 - z**2)
    p = np.stack([r * np.cos(ang), r * np.sin(ang), np.full(n, z)], axis=1)
    return p, -p / np.linalg.norm(p, axis=1, keepdims=True)


def box_faces(points_plus_x, points_minus_x, half=25.0):
    """Contacts on the +x face (pushing -x) and the -x face (pushing +x) of a box of half-width ``half``."""
    p = [(half, y, z) for y, z in points_plus_x] + [(-half, y, z) for y, z in points_minus_x]
    n = [(-1.0, 0, 0)] * len(points_plus_x) + [(1.0, 0, 0)] * len(points_minus_x)
    return np.array(p, float), np.array(n, float)


# -- the hand-computed case -------------------------------------------------------------
@pytest.mark.parametrize("mu, torsion_mm", [(0.5, 2.0), (0.5, 20.0), (0.3, 5.0), (1.0, 40.0)])
def test_epsilon_of_a_soft_antipodal_pinch_matches_the_hand_computed_value(mu, torsion_mm):
    """Two soft fingers at +-a e_x of a sphere of radius a, torques scaled by rho = a, four cone edges.

    With u = (a_x, a_y, a_z, b_x, b_y, b_z) and p, q, r, s = (a_y +- b_z)/sqrt2, (a_z -+ b_y)/sqrt2,
    the polar of the hull is {sqrt2 mu |p|, sqrt2 mu |r| <= 1 + a_x; sqrt2 mu |q|, sqrt2 mu |s| <= 1 - a_x;
    g |b_x| <= 1 - |a_x|} (g = gamma / rho), whose farthest vertex from the origin lies at a_x = 0 or
    |a_x| = 1 (|u|^2 is convex in a_x there).  So eps = 1 / R with
    R^2 = max(2 / mu^2 + 1 / g^2, 1 + 4 / mu^2).
    """
    a = 20.0
    p, n = pinch(a)
    q = contact_quality(p, n, ORIGIN, a, QualityOptions(friction=mu, cone_edges=4, torsion_mm=torsion_mm))
    g = torsion_mm / a
    expected = 1.0 / np.sqrt(max(2 / mu**2 + 1 / g**2, 1 + 4 / mu**2))
    assert q.force_closure
    assert q.epsilon == pytest.approx(expected, rel=1e-9)


def test_a_hard_finger_pinch_is_not_force_closure():
    p, n = pinch()
    q = contact_quality(p, n, ORIGIN, 20.0, QualityOptions(friction=0.5, cone_edges=8))
    assert not q.force_closure and q.epsilon == 0.0 and q.volume == 0.0
    assert force_closure(primitive_wrenches(p, n, ORIGIN, 20.0, QualityOptions()).reshape(-1, 6)).rank == 5


# -- known closures and non-closures ----------------------------------------------------
@pytest.mark.parametrize("fingers", [3, 4, 5])
def test_hard_fingers_around_a_sphere_are_force_closure(fingers):
    p, n = equator(fingers)
    q = contact_quality(p, n, ORIGIN, 30.0, QualityOptions(friction=0.5))
    assert q.force_closure and q.epsilon > 0.01 and q.volume > 0


def test_four_fingers_on_opposite_faces_of_a_box_are_force_closure():
    p, n = box_faces([(-20, 5), (0, 5), (20, 5)], [(0, -5)])
    q = contact_quality(p, n, ORIGIN, 40.0, QualityOptions(friction=0.6))
    assert q.force_closure and q.epsilon > 0.01


@pytest.mark.parametrize("torsion_mm", [0.0, 10.0])
def test_contacts_all_on_one_face_are_not_force_closure(torsion_mm):
    p, n = box_faces([(-20, 15), (0, 15), (20, 15), (0, -15)], [])
    q = contact_quality(p, n, ORIGIN, 40.0, QualityOptions(friction=0.6, torsion_mm=torsion_mm))
    assert not q.force_closure
    assert q.epsilon == 0.0 and q.volume == 0.0  # every force pushes into the face: a flat hull


def test_contacts_on_one_hemisphere_are_not_force_closure():
    p, n = equator(4, z=20.0)  # every normal points down into the sphere: nothing pulls it down
    q = contact_quality(p, n, ORIGIN, 30.0, QualityOptions(friction=0.3))
    assert not q.force_closure and q.epsilon == 0.0
    distance, _ = hull_measures(primitive_wrenches(p, n, ORIGIN, 30.0, QualityOptions(friction=0.3)).reshape(-1, 6))
    assert distance < 0  # the origin lies outside the hull


# -- properties over random grasps ------------------------------------------------------
def random_grasp(rng, n_contacts):
    """Contacts on a random sphere-ish object: points on a sphere of radius 30, normals to the centre tilted a little."""
    d = rng.normal(size=(n_contacts, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = -d + 0.2 * rng.normal(size=(n_contacts, 3))
    return 30 * d, n / np.linalg.norm(n, axis=1, keepdims=True)


def test_the_closure_lp_agrees_with_the_hull(rng):
    seen = {True: 0, False: 0}
    for _ in range(80):
        p, n = random_grasp(rng, int(rng.integers(2, 6)))
        opts = QualityOptions(friction=float(rng.uniform(0.1, 0.8)), torsion_mm=float(rng.choice([0.0, 5.0])))
        W = primitive_wrenches(p, n, ORIGIN, 30.0, opts).reshape(-1, 6)
        distance, _ = hull_measures(W)
        if abs(distance) < 1e-7:
            continue  # on the boundary: either answer is within rounding
        assert force_closure(W).force_closure == (distance > 0)
        seen[distance > 0] += 1
    assert seen[True] >= 10 and seen[False] >= 10


def test_epsilon_does_not_depend_on_the_frame(rng):
    """Moving the object moves every wrench rigidly.  Translations keep the friction pyramids; a
    rotation turns their edges about the normals (the tangent basis follows the coordinate axes),
    so it is checked exactly on frictionless soft fingers, whose wrench sets have no edges."""
    closed = 0
    for _ in range(10):
        p, n = random_grasp(rng, 7)
        centre = rng.normal(size=3)
        t = rng.normal(scale=50, size=3)
        opts = QualityOptions(friction=0.5, torsion_mm=3.0)
        q0 = contact_quality(p, n, centre, 30.0, opts)
        q1 = contact_quality(p + t, n, centre + t, 30.0, opts)
        assert (q1.force_closure, q1.epsilon) == (q0.force_closure, pytest.approx(q0.epsilon, abs=1e-9))
        R = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
        soft = QualityOptions(friction=0.0, torsion_mm=10.0)
        q0 = contact_quality(p, n, centre, 30.0, soft)
        q1 = contact_quality(p @ R.T + t, n @ R.T, R @ centre + t, 30.0, soft)
        assert q1.force_closure == q0.force_closure
        assert q1.epsilon == pytest.approx(q0.epsilon, abs=1e-9)
        assert q1.volume == pytest.approx(q0.volume, rel=1e-6, abs=1e-12)
        closed += q0.force_closure
    assert closed >= 2


def test_more_friction_or_more_contacts_never_lower_epsilon(rng):
    for _ in range(10):
        p, n = random_grasp(rng, 5)
        eps = [contact_quality(p, n, ORIGIN, 30.0, QualityOptions(friction=mu)).epsilon for mu in (0.2, 0.4, 0.8)]
        assert eps[0] <= eps[1] + 1e-12 <= eps[2] + 2e-12
        fewer = contact_quality(p[:4], n[:4], ORIGIN, 30.0, QualityOptions(friction=0.5)).epsilon
        assert fewer <= contact_quality(p, n, ORIGIN, 30.0, QualityOptions(friction=0.5)).epsilon + 1e-12


def test_cone_edges_lie_on_the_friction_cone_and_torques_are_arm_cross_force(rng):
    p, n = random_grasp(rng, 3)
    centre = rng.normal(size=3)
    W = primitive_wrenches(p, n, centre, 25.0, QualityOptions(friction=0.4, cone_edges=6, torsion_mm=2.0))
    assert W.shape == (3, 8, 6)
    f, tau = W[..., :3], W[..., 3:] * 25.0
    assert np.allclose(np.einsum("cgi,ci->cg", f, n), 1.0)  # unit normal component
    tangential = np.linalg.norm(f - np.einsum("cgi,ci->cg", f, n)[..., None] * n[:, None], axis=-1)
    assert np.allclose(tangential[:, :6], 0.4) and np.allclose(tangential[:, 6:], 0.0)
    arm = (p - centre)[:, None, :]
    spin = np.einsum("cgi,ci->cg", tau - np.cross(arm, f), n)  # the moment about the normal beyond arm x f
    assert np.allclose(spin[:, :6], 0.0) and np.allclose(spin[:, 6], 2.0) and np.allclose(spin[:, 7], -2.0)


# -- grasp_quality on a solution ----------------------------------------------------------
def test_grasp_quality_reads_contacts_in_the_object_frame(rng):
    obj = GraspObject("ball", {"a": PointRegion((0, 0, 30), (0, 0, 1))}, (Sphere((0, 0, 0), 30.0),))
    task = SimpleNamespace(object=obj)
    p, n = equator(3)
    R = Rotation.random(random_state=7).as_matrix()
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, (100.0, -20.0, 5.0)
    contacts = [SimpleNamespace(object_point=R @ pi + T[:3, 3], object_normal=R @ -ni) for pi, ni in zip(p, n)]
    got = grasp_quality(task, SimpleNamespace(T_palm_object=T, contacts=contacts), QualityOptions(friction=0.5))
    centre, radius = object_reference(obj)
    direct = contact_quality(p, n, centre, radius, QualityOptions(friction=0.5))
    assert got.force_closure and got.epsilon == pytest.approx(direct.epsilon, abs=1e-12)
    assert np.allclose(got.center_mm, 0.0, atol=1e-9) and got.radius_mm == pytest.approx(30.0, rel=1e-3)
    stated = grasp_quality(task, SimpleNamespace(T_palm_object=T, contacts=contacts), QualityOptions(radius_mm=10.0))
    assert stated.radius_mm == 10.0 and stated.options.radius_mm == 10.0


# -- the object's solid ---------------------------------------------------------------------
def test_a_box_solid_has_the_exact_volume_centroid_and_inertia():
    obj = GraspObject("box", {}, (Box((1.0, 2.0, 3.0), (40.0, 20.0, 10.0)),))
    solid = object_solid(obj)
    mp = mass_properties(solid)
    assert solid.source == "primitives" and solid.convex == (True,)
    assert mp.volume_mm3 == pytest.approx(8000.0)
    assert np.allclose(mp.centroid_mm, (1, 2, 3))
    V, (a, b, c) = 8000.0, (40.0, 20.0, 10.0)
    expected = V / 12 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    assert np.allclose(mp.inertia_mm5, expected)
    centre, radius = object_reference(obj)
    assert radius == pytest.approx(np.sqrt(20**2 + 10**2 + 5**2))


def test_round_solids_are_close_to_their_exact_volume():
    sphere = mass_properties(object_solid(GraspObject("s", {}, (Sphere((0, 0, 0), 10.0),))))
    assert sphere.volume_mm3 == pytest.approx(4 / 3 * np.pi * 1000, rel=0.01)
    torus = object_solid(GraspObject("t", {}, (Torus((0, 0, 5), (0, 0, 1), 28.0, 7.0),)))
    assert len(torus.pieces) == 16 and all(torus.convex)
    mp = mass_properties(torus)
    assert mp.volume_mm3 == pytest.approx(2 * np.pi**2 * 28 * 49, rel=0.03)
    assert np.allclose(mp.centroid_mm, (0, 0, 5), atol=1e-6)


def test_an_object_with_regions_only_is_the_hull_of_its_regions():
    obj = GraspObject("slab", {
        "top": PointRegion((0, 0, 5), (0, 0, 1)), "a": PointRegion((10, 0, -5), (0, 0, -1)),
        "b": PointRegion((0, 10, -5), (0, 0, -1)), "c": PointRegion((-10, -10, -5), (0, 0, -1)),
    })  # fmt: skip
    assert object_solid(obj).source == "regions"
    two_points = GraspObject("two", {"A": PointRegion((0, 0, 0), (-1, 0, 0)), "B": PointRegion((40, 0, 0), (-1, 0, 0))})
    with pytest.raises(InvalidObject, match="has no solid shape.*display primitives or a mesh"):
        object_solid(two_points)
    centre, radius = object_reference(two_points)  # no solid: the regions' centroid and extent
    assert np.allclose(centre, (20, 0, 0)) and radius == pytest.approx(20.0)
    one_point = GraspObject("one", {"A": PointRegion((0, 0, 0), (-1, 0, 0))})
    with pytest.raises(InvalidObject, match="no size to scale torques.*radius_mm"):
        object_reference(one_point)


def test_a_mesh_file_is_one_piece_convex_or_not(tmp_path):
    cube = tmp_path / "cube.off"
    v = [(x, y, z) for x in (0, 10) for y in (0, 10) for z in (0, 10)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    cube.write_text("OFF\n8 6 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in v) + "".join(f"4 {a} {b} {c} {d}\n" for a, b, c, d in quads))
    solid = object_solid(GraspObject("cube", {}, (), str(cube)))
    assert solid.source == "mesh file" and solid.convex == (True,)
    assert mass_properties(solid).volume_mm3 == pytest.approx(1000.0)
    # an L: two cubes side by side along x with one lifted: its hull is larger than itself
    mesh_l = solid.pieces[0]
    both = np.concatenate([mesh_l.vertices, mesh_l.vertices + (10, 0, 10)])
    faces = np.concatenate([mesh_l.faces, mesh_l.faces + 8])
    lines = ["OFF", f"16 {len(faces)} 0"] + [f"{x} {y} {z}" for x, y, z in both] + [f"3 {a} {b} {c}" for a, b, c in faces]
    (tmp_path / "l.off").write_text("\n".join(lines))
    assert object_solid(GraspObject("L", {}, (), str(tmp_path / "l.off"))).convex == (False,)


# -- options ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, message", [
    ({"friction": -0.1}, "friction must be a number >= 0"),
    ({"friction": float("nan")}, "friction must be a number >= 0"),
    ({"cone_edges": 2}, "cone_edges must be an integer >= 3"),
    ({"cone_edges": 4.0}, "cone_edges must be an integer >= 3"),
    ({"torsion_mm": -1}, "torsion_mm must be a number of mm >= 0"),
    ({"radius_mm": 0}, "radius_mm must be a positive number of mm"),
    ({"center_mm": (0, 1)}, "center_mm must be three finite numbers"),
])  # fmt: skip
def test_bad_quality_options_are_refused_by_name(kwargs, message):
    with pytest.raises(PrehensionError, match=message):
        QualityOptions(**kwargs)


def test_quality_options_round_trip_and_refuse_unknown_keys():
    opts = QualityOptions(friction=0.3, cone_edges=6, torsion_mm=2.5, radius_mm=40.0, center_mm=(1, 2, 3))
    assert QualityOptions.from_dict(opts.to_dict()) == opts
    with pytest.raises(PrehensionError, match=r"unknown \['mu'\]"):
        QualityOptions.from_dict({"mu": 0.5})
