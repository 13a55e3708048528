"""Hand-object collision: capsule depths, the residual checks, pads, idle fingers, the viewer."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.pregrasp import approach_entries_of
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
from prehension.tasks.object_collision import _kept_pieces, batch_link_depths, link_penetrations, pad_penetrations
from prehension.verification.residuals import Tolerances, evaluate


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

def test_pad_exception_excuses_only_the_capsule_balls_inside_the_pad():
    a, b = np.zeros(3), np.array([10.0, 0, 0])
    pieces = _kept_pieces(a, b, 1.0, [(np.array([5.0, 0, 0]), 3.0)])  # B(s, 1) in B(c, 3): |s - c| <= 2
    np.testing.assert_allclose([p[0][0] for p in pieces], [0.0, 7.0])
    np.testing.assert_allclose([p[1][0] for p in pieces], [3.0, 10.0])
    assert _kept_pieces(a, b, 1.0, [(np.array([5.0, 50, 0]), 3.0)])[0][1][0] == 10.0  # far pad: whole segment
    assert _kept_pieces(a, b, 1.0, [(np.array([5.0, 0, 0]), 20.0)]) == []  # inside a large pad
    for rho in (1.0, 0.5, 0.0):  # a pad no thicker than the capsule holds none of its balls
        assert len(_kept_pieces(a, b, 1.0, [(np.array([5.0, 0, 0]), rho)])) == 1
    rng = np.random.default_rng(3)  # the kept pieces are exactly the balls not inside the pad
    for _ in range(200):
        c, rho, r = rng.normal(scale=6.0, size=3), rng.uniform(0, 8), rng.uniform(0.5, 6)
        u = np.linspace(0, 1, 401)
        pts = a + u[:, None] * (b - a)
        inside = np.linalg.norm(pts - c, axis=1) + r <= rho
        kept = np.zeros(len(u), bool)
        for p0, p1 in _kept_pieces(a, b, r, [(c, rho)]):
            kept |= (u >= p0[0] / 10 - 1e-12) & (u <= p1[0] / 10 + 1e-12)
        boundary = np.abs(np.linalg.norm(pts - c, axis=1) + r - rho) < 1e-6
        assert np.all((kept == ~inside) | boundary)


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


@pytest.mark.parametrize("name", ["scalpel-upholding", "teapot-lid-lifting"])
def test_what_a_pad_excuses_is_never_deeper_than_the_pad(name):
    """Excusing only capsule balls inside the pad ball lowers a link's depth at most to
    the pad's own depth, which is checked: a hand sunk through its fingertips is caught
    by the pad rows whether or not anything is excused."""
    task = load_builtin_task(name)
    config = solve(task, "local").solutions[0].configuration()
    for dz in (0.0, -2.0, -6.0):  # the solved grasp, then the object pushed into the hand
        T = config.T_palm_object.copy()
        T[:3, 3] += T[:3, :3] @ np.array([0.0, 0.0, dz])
        moved = Configuration(config.joint_angles, T, config.contact_params)
        pose = forward_kinematics(task.hand, config.joint_angles)
        report = evaluate(task, moved)
        points = [(s.hand_point - T[:3, 3]) @ T[:3, :3] for s in report.contacts]
        with_pads, without = link_penetrations(task, pose, T, points), link_penetrations(task, pose, T)
        pads = pad_penetrations(task, pose, T, points)
        assert set(pads) == {c.name for c in task.contacts}
        assert {c.name: c.value for c in report.checks if c.kind == "pad_collision"} == pads
        for c in task.contacts:
            link = task.hand_region(c).link
            assert with_pads[link] <= without[link] + 1e-12
            assert without[link] <= max(with_pads[link], max(pads.values())) + 0.125 + 1e-9


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
    from prehension.viewer import build_scene
    from prehension.viewer.model import PENETRATION_COLOR

    task, config = scalpel
    T = np.eye(4)
    T[:3, 3] = [-2.0, 0.0, 55.0]
    scene = build_scene(task, Configuration(config.joint_angles, T))
    assert any(m.color == PENETRATION_COLOR for m in scene.layer("hand").meshes)
    assert any(line.startswith("into the object (red): palm") for line in scene.caption)
    clear = build_scene(task, config)
    assert not any(m.color == PENETRATION_COLOR for m in clear.layer("hand").meshes)


COLLIDING = ("guitar-tuning", "scalpel-handling", "scalpel-upholding", "teapot-service", "teapot-lid-lifting")


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
    signed distance, only the capsule balls inside a contact's pad ball left out, and the
    pad balls' own surface points."""
    from prehension.hands.collision import collision_pairs

    task = load_builtin_task(name)
    config = solve(task, "local").solutions[0].configuration()
    report = evaluate(task, config)
    pose = forward_kinematics(task.hand, config.joint_angles)
    T = config.T_palm_object
    shapes = collision_pairs(task.hand)
    pads = {task.hand_region(c).link: [] for c in task.contacts}
    for c, s in zip(task.contacts, report.contacts):
        rho = task.hand_region(c).region.radius  # the built-in hand's regions are caps
        centre = (s.hand_point - rho * s.hand_normal - T[:3, 3]) @ T[:3, :3]
        pads[task.hand_region(c).link].append((centre, rho))
        points, _ = _capsule_surface_points(centre, centre, rho, n_axis=1)
        assert task.object.distance.signed_distance(points).min() >= -0.5, c.name
    for s in range(len(shapes.radius)):
        li = shapes.link[s]
        R, r = pose.R_palm_link[0, li], pose.r_palm_link[0, li]
        a, b = [((R @ p + r) - T[:3, 3]) @ T[:3, :3] for p in (shapes.a[s], shapes.b[s])]
        points, centres = _capsule_surface_points(a, b, shapes.radius[s])
        keep = np.ones(len(points), bool)
        for h, rho in pads.get(task.hand.link_names[li], []):
            keep &= np.linalg.norm(centres - h, axis=1) > rho - shapes.radius[s]
        if keep.any():
            assert task.object.distance.signed_distance(points[keep]).min() >= -0.5, task.hand.link_names[li]


def test_viewer_draws_pads_in_their_colour_and_a_sunk_pad_red(scalpel):
    """Each fingertip cap's ball is drawn in the pad colour; pushing the object 3 mm into
    the hand along a contact's normal sinks that pad: red, and named in the caption."""
    from prehension.viewer import build_scene
    from prehension.viewer.model import CONTACT_COLORS, PAD_COLOR, PENETRATION_COLOR

    assert PAD_COLOR not in CONTACT_COLORS + (PENETRATION_COLOR,)
    task, config = scalpel
    clear = build_scene(task, config)
    assert [m.color for m in clear.layer("pads").meshes] == [PAD_COLOR]
    assert not any("pad" in line for line in clear.caption)
    state = evaluate(task, config).contacts[0]
    T = config.T_palm_object.copy()
    T[:3, 3] -= 3.0 * state.hand_normal  # the object into the pad, along its normal
    scene = build_scene(task, Configuration(config.joint_angles, T, config.contact_params))
    assert PENETRATION_COLOR in [m.color for m in scene.layer("pads").meshes]
    assert any(f"{task.contacts[0].name} pad" in line for line in scene.caption if line.startswith("into the object (red)"))


def test_result_file_carries_each_link_and_pad_depth_and_check_re_derives_them(tmp_path):
    """The result file states each link's and each pad's depth; ``check`` re-derives them,
    catches an edited one, and reads a file written before they were stored."""
    import json

    from prehension.results import write_result
    from prehension.quality import quality_entries
    from prehension.verification import verify_result_file

    task = load_builtin_task("scalpel-upholding")
    result = solve(task, "local")
    path = tmp_path / "r.json"
    write_result(result, path, quality_entries(result), approach_entries_of(result))
    data = json.loads(path.read_text())
    depths = data["solutions"][0]["object_depths_mm"]
    report = result.solutions[0].report
    assert depths["links"] == {c.name: c.value for c in report.checks if c.kind == "object_collision"}
    assert set(depths["pads"]) == {c.name for c in task.contacts}

    def finding(d):
        path.write_text(json.dumps(d))
        found = verify_result_file(path).findings
        return next(f for f in found if f.what.endswith("each link's and each pad's depth in the object")), found

    ok, _ = finding(data)
    assert ok.ok and "deepest" in ok.detail
    edited = json.loads(json.dumps(data))
    edited["solutions"][0]["object_depths_mm"]["pads"][task.contacts[0].name] += 0.01
    bad, _ = finding(edited)
    assert not bad.ok and f"pads {task.contacts[0].name}" in bad.detail
    old = json.loads(json.dumps(data))  # as written before issue 26: no depths, no pad kind
    del old["solutions"][0]["object_depths_mm"]
    del old["solutions"][0]["worst"]["pad_collision"]
    before, found = finding(old)
    assert before.ok and "not stated" in before.detail and all(f.ok for f in found)
