"""Hand-object collision: capsule depths, the residual checks, pads, idle fingers, the viewer."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.geometry.regions import PointRegion
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.distance import MeshDistance
from prehension.objects.meshes import Box
from prehension.objects.model import GraspObject
from prehension.objects.solid import PrimitiveSolid
from prehension.solve import solve
from prehension.tasks.idle import idle_fingers, settle_idle_fingers
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Configuration, Contact, Task
from prehension.tasks.object_collision import _kept_pieces, batch_link_depths, link_penetrations
from prehension.tasks.residuals import Tolerances, evaluate


def _boxes(pieces: int):
    """One box, or two overlapping boxes as one mesh of two pieces (signs by winding number)."""
    import trimesh

    box = trimesh.creation.box(extents=(40.0, 30.0, 20.0))
    if pieces == 1:
        return box.vertices, box.faces
    other = trimesh.creation.box(extents=(20.0, 20.0, 20.0))
    other.apply_translation((15.0, 10.0, 10.0))
    return np.vstack([box.vertices, other.vertices]), np.vstack([box.faces, other.faces + len(box.vertices)])


@pytest.mark.parametrize("pieces", [1, pytest.param(2, marks=pytest.mark.slow)])  # 2: ~17 s
def test_capsule_depth_is_radius_minus_the_least_signed_distance(rng, pieces):
    """Segments from inside and outside the mesh's bounding box (whose outside needs no sign
    query), wholly inside, wholly outside and crossing, on one piece and on two."""
    md = MeshDistance(*_boxes(pieces))
    assert md.arrays.robust_sign == (pieces == 2)
    a = rng.uniform(-40, 40, size=(200, 3))
    b = a + rng.normal(scale=12.0, size=(200, 3))
    r = rng.uniform(1.0, 8.0, size=200)
    depth = md.capsule_depth(a, b, r)
    t = np.linspace(0, 1, 4001)
    for i in range(200):
        least = md.signed_distance(a[i] + t[:, None] * (b[i] - a[i])).min()
        expected = max(0.0, r[i] - least)
        step = np.linalg.norm(b[i] - a[i]) / 4000
        assert expected - 0.125 - step - 1e-9 <= depth[i] <= expected + step + 1e-9  # sampled inside: from below
        if least > 0:  # outside: exact
            assert depth[i] == pytest.approx(max(0.0, r[i] - least), abs=step + 1e-9)



@pytest.mark.parametrize("cap", [0.0, 0.25, 2.0, 6.0])
def test_capped_capsule_depth_answers_the_same_yes_no_question(rng, cap):
    """With a cap, every depth at most the cap is the depth; above it, some value above it."""
    import trimesh

    box = trimesh.creation.box(extents=(40.0, 30.0, 20.0))
    md = MeshDistance(box.vertices, box.faces)
    a = rng.uniform(-40, 40, size=(400, 3))
    b = a + rng.normal(scale=12.0, size=(400, 3))
    r = rng.uniform(0.1, 8.0, size=400)
    exact, capped = md.capsule_depth(a, b, r), md.capsule_depth(a, b, r, cap=cap)
    np.testing.assert_array_equal(exact <= cap, capped <= cap)
    np.testing.assert_array_equal(capped[exact <= cap], exact[exact <= cap])
    assert np.all(capped <= exact + 1e-12)  # never more than the depth: a lower bound
    assert (exact > cap).sum() > 10 and (exact <= cap).sum() > 10  # both answers occur

def test_pad_exception_cuts_the_segment_around_the_contact():
    a, b = np.zeros(3), np.array([10.0, 0, 0])
    pieces = _kept_pieces(a, b, 1.0, [(np.array([5.0, 0, 0]), 1.0)])
    np.testing.assert_allclose([p[0][0] for p in pieces], [0.0, 7.0])
    np.testing.assert_allclose([p[1][0] for p in pieces], [3.0, 10.0])
    assert _kept_pieces(a, b, 1.0, [(np.array([5.0, 50, 0]), 1.0)])[0][1][0] == 10.0  # far ball: whole segment
    assert _kept_pieces(a, b, 20.0, [(np.array([5.0, 0, 0]), 1.0)]) == []  # swallowed


@pytest.fixture(scope="module")
def scalpel():
    task = load_builtin_task("scalpel-upholding")
    result = solve(task, "local")
    assert result.success
    return task, result.solutions[0].configuration()


def test_solved_builtin_is_clear_and_a_displaced_object_is_caught(scalpel):
    task, config = scalpel
    report = evaluate(task, config)
    checks = [c for c in report.checks if c.kind == "object_collision"]
    assert {c.name for c in checks} == {l.name for l in task.hand.links if l.collision}
    assert report.ok and max(c.value for c in checks) <= 0.5
    T = np.eye(4)
    T[:3, 3] = [-2.0, 0.0, 55.0]  # the handle through the middle of the palm
    moved = Configuration(config.joint_angles, T)
    bad = evaluate(task, moved)
    palm = next(c for c in bad.checks if c.kind == "object_collision" and c.name == "palm")
    assert palm.value > 10 and not palm.ok
    assert "object_collision palm:" in bad.summary() and "mm (tolerance 0.5) FAILED" in bad.summary()
    assert evaluate(task, moved, Tolerances(object_penetration_mm=1e3)).worst("object_collision") == palm.value


def test_excepting_pads_only_lowers_depths():
    task = load_builtin_task("scalpel-incision")  # the palm pad touches the handle
    config = solve(task, "local").solutions[0].configuration()
    pose = forward_kinematics(task.hand, config.joint_angles)
    report = evaluate(task, config)
    T = config.T_palm_object
    points = [(s.hand_point - T[:3, 3]) @ T[:3, :3] for s in report.contacts]
    with_pads = link_penetrations(task, pose, T, points)
    without = link_penetrations(task, pose, T)
    assert all(with_pads[k] <= without[k] + 1e-12 for k in without)
    assert max(without.values()) > max(with_pads.values())  # the fingertips do touch the handle


def _box_task(centre, size=(24.0, 24.0, 24.0)):
    hand = load_builtin_task("scalpel-upholding").hand
    top = (centre[0], centre[1], centre[2] + size[2] / 2)
    obj = GraspObject("box", {"top": PointRegion(top, (0, 0, 1))}, solid=PrimitiveSolid((Box(tuple(centre), size),)))
    return Task("box", hand, obj, (Contact("index_tip", "top"),), ("index",))


def test_idle_finger_through_the_object_is_moved_clear():
    probe = _box_task((0.0, 0.0, -500.0))
    q0 = probe.idle_vector
    pose = forward_kinematics(probe.hand, q0)
    tip = pose.r_palm_link[0, probe.hand.link_index("middle_distal")]
    task = _box_task(tuple(tip))
    names = [name for name, _, _ in idle_fingers(task)]
    assert "middle" in names and "index" not in names
    config = Configuration(q0, np.eye(4))
    links = [task.hand.link_index(n) for n in task.hand.finger("middle").links]
    assert batch_link_depths(task, pose, np.eye(4), links).max() > 5  # inside at first
    settled = settle_idle_fingers(task, config)
    moved = settled.joint_angles != q0
    assert moved.any() and not (moved & task.active_mask).any()  # only idle dofs move ...
    q, idle = settled.joint_angles, ~task.active_mask
    assert np.all(q[idle] >= task.hand.lower[idle]) and np.all(q[idle] <= task.hand.upper[idle])  # within limits
    after = forward_kinematics(task.hand, settled.joint_angles)
    assert batch_link_depths(task, after, np.eye(4), links).max() <= 0.25  # ... clear of the object
    again = settle_idle_fingers(task, config)
    np.testing.assert_array_equal(again.joint_angles, settled.joint_angles)  # deterministic
    assert settle_idle_fingers(task, settled) is settled  # already clear: unchanged


def test_viewer_paints_penetrating_links_red(scalpel):
    from prehension.viewer.scene import PENETRATION_COLOR, build_scene

    task, config = scalpel
    T = np.eye(4)
    T[:3, 3] = [-2.0, 0.0, 55.0]
    scene = build_scene(task, Configuration(config.joint_angles, T))
    assert any(m.color == PENETRATION_COLOR for m in scene.layer("hand").meshes)
    assert any(line.startswith("into the object (red): palm") for line in scene.caption)
    clear = build_scene(task, config)
    assert not any(m.color == PENETRATION_COLOR for m in clear.layer("hand").meshes)


COLLIDING = ("guitar-tuning", "scalpel-handling", "scalpel-incision", "scalpel-upholding", "teapot-service")


def _capsule_surface_points(a, b, r, n_axis=24, n_dirs=64):
    """Points on a capsule's surface (the ball of radius r swept along a-b), (K, 3)."""
    golden = np.pi * (3 - np.sqrt(5))
    k = np.arange(n_dirs)
    z = 1 - 2 * (k + 0.5) / n_dirs
    dirs = np.stack([np.sqrt(1 - z**2) * np.cos(golden * k), np.sqrt(1 - z**2) * np.sin(golden * k), z], 1)
    centres = a + np.linspace(0, 1, n_axis)[:, None] * (b - a)
    return (centres[:, None, :] + r * dirs[None]).reshape(-1, 3), np.repeat(centres, n_dirs, axis=0)


@pytest.mark.parametrize("name", COLLIDING)
def test_colliding_builtin_answers_clear_the_mesh_at_sampled_capsule_points(name):
    """Independent of link_penetrations: points on every capsule surface against the mesh's
    signed distance, the pad zones at the contacts left out as documented."""
    from prehension.hands.collision import collision_pairs

    task = load_builtin_task(name)
    config = solve(task, "local").solutions[0].configuration()
    report = evaluate(task, config)
    pose = forward_kinematics(task.hand, config.joint_angles)
    T = config.T_palm_object
    shapes = collision_pairs(task.hand)
    hand_points = {task.hand_region(c).link: [] for c in task.contacts}
    for c, s in zip(task.contacts, report.contacts):
        hr = task.hand_region(c)
        rho = hr.region.radius if hasattr(hr.region, "radius") else max(cap.radius for cap in task.hand.links[task.hand.link_index(hr.link)].collision)
        hand_points[hr.link].append(((s.hand_point - T[:3, 3]) @ T[:3, :3], rho))
    for s in range(len(shapes.radius)):
        li = shapes.link[s]
        R, r = pose.R_palm_link[0, li], pose.r_palm_link[0, li]
        a, b = [((R @ p + r) - T[:3, 3]) @ T[:3, :3] for p in (shapes.a[s], shapes.b[s])]
        points, centres = _capsule_surface_points(a, b, shapes.radius[s])
        keep = np.ones(len(points), bool)
        for h, rho in hand_points.get(task.hand.link_names[li], []):
            keep &= np.linalg.norm(centres - h, axis=1) >= shapes.radius[s] + rho
        if keep.any():
            assert task.object.distance.signed_distance(points[keep]).min() >= -0.5, task.hand.link_names[li]
