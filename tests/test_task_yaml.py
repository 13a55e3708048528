"""Tests of prehension.tasks.yaml_io: the task file format."""

from __future__ import annotations

import dataclasses
import math
import os
import re
import stat
from pathlib import Path

import numpy as np
import pytest
import yaml

from prehension.errors import InvalidTask
from prehension.geometry.bezier import BezierPatch
from prehension.geometry.regions import BezierRegion, PointRegion, SphereCap
from prehension.geometry.rotations import rotation_about
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link
from prehension.hands.sa_hand import SA_TIP_AXIS, SA_TIP_CENTER_MM, schunk_sa_hand
from prehension.objects.meshes import Box, Cylinder, Ellipsoid, Sphere, Torus
from prehension.objects.model import GraspObject
from prehension.tasks.format.schema import PRIMITIVES
from prehension.tasks.model import Contact, Task
from prehension.tasks.yaml_io import (
    BUILTIN_HANDS,
    FORMAT_TAG,
    dump_task,
    dumps_task,
    hand_from_dict,
    hand_to_dict,
    load_task,
    loads_task,
    region_from_dict,
    region_to_dict,
    task_from_dict,
    task_to_dict,
)

from conftest import random_angles

DOCS = Path(__file__).resolve().parents[1] / "docs" / "task-format.md"
RAD = math.radians


# -- fixtures ---------------------------------------------------------------------------
def _object() -> GraspObject:
    net = [[(0, 0, 0), (0, 10, 1), (0, 20, 0)], [(10, 0, 1), (10, 10, 2), (10, 20, 1)]]
    regions = {
        "face": BezierRegion(BezierPatch(np.array(net, dtype=float))),
        "rim": PointRegion((5.0, -3.0, 2.5), (0.2, -1.0, 0.3)),
        "bump": SphereCap((1.0, 2.0, 3.0), 6.5, (0.3, -0.2, 1.0), RAD(47.3)),
    }
    prims = (
        Box((0.0, 0.0, 0.0), (10.0, 20.0, 30.0)),
        Sphere((1.0, 1.0, 1.0), 4.0),
        Ellipsoid((0.0, 0.0, 5.0), (3.0, 4.0, 5.0), resolution=12),
        Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 40.0), 5.0, end_radius=3.0),
        Torus((0.0, 0.0, 10.0), (0.0, 1.0, 1.0), 20.0, 2.5),
    )
    return GraspObject("widget", regions, prims)


def _sa_modified_task() -> Task:
    sa = schunk_sa_hand()
    hand = sa.with_limits({"index_mcp_abd": (RAD(-22.5), RAD(22.5)), "thumb_base": (RAD(10), RAD(80))})
    hand = hand.without_couplings().with_regions(
        {
            "index_tip": HandRegion("index_distal", SphereCap(SA_TIP_CENTER_MM, 13.0, SA_TIP_AXIS, RAD(75))),
            "index_pad": HandRegion("index_distal", PointRegion((20.0, 0.0, 13.0), (0.0, 0.1, 1.0))),
        }
    )
    contacts = (Contact("index_tip", "face"), Contact("thumb_tip", "bump", name="thumb-bump"), Contact("palm", "rim"))
    return Task(
        "sa-modified", hand, _object(), contacts, ("index", "thumb"), "modified SA hand", {"ring_mcp_flex": RAD(10)}
    )


PERMUTATION = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def _custom_hand(tip_rotation=np.eye(3)) -> Hand:
    links = (
        Link("palm", (Capsule((0, -30, 0), (0, 30, 0), 15.0), Capsule((0, 0, 20), (0, 0, 20), 9.0))),
        Link("left_prox", (Capsule((5, 0, 0), (35, 0, 0), 8.0),)),
        Link("left_dist", (Capsule((10, 0, 0), (10, 0, 0), 7.0),)),
        Link("right"),
    )
    joints = (
        Joint("left_base", "universal", "palm", "left_prox", (0, 20, 40), (0, 0, 0), (1, 0, 0), PERMUTATION,
              ("left_abd", "left_flex"), (RAD(-15), 0.0), (RAD(15), RAD(90)), axis_in_child=(0, 1, 0)),
        Joint("left_tip", "revolute", "left_prox", "left_dist", (40, 0, 0), (-2, 0, 0.5), (0, 3, 4), tip_rotation,
              ("left_tip",), (RAD(5),), (RAD(80),)),
        Joint("right_base", "revolute", "palm", "right", (0, -20, 40), (0, 0, 0), (0.1, -1, 0.2), np.eye(3),
              ("right_flex",), (0.0,), (RAD(90),)),
    )  # fmt: skip
    net = np.array([[(20, -5, 8), (20, 5, 8)], [(30, -5, 8), (30, 5, 8.5)], [(40, -5, 7), (40, 5, 7)]], float)
    regions = {
        "left_pad": HandRegion("left_dist", SphereCap((20, 0, 0), 8.0, (0.3, 0.1, 1.0), RAD(55))),
        "right_pad": HandRegion("right", PointRegion((30, 0, 8), (1, 1, 3))),
        "right_face": HandRegion("right", BezierRegion(BezierPatch(net))),
    }
    return Hand(
        "gripper", links, joints, (Coupling("left_tip", "left_flex", 0.75, RAD(5)),),
        (Finger("left", ("left_prox", "left_dist")), Finger("right", ("right",))),
        regions, (("left_dist", "right"),),
    )  # fmt: skip


def _custom_task(hand: Hand | None = None) -> Task:
    hand = hand or _custom_hand()
    contacts = (Contact("left_pad", "face"), Contact("right_pad", "rim", name="right-on-rim"))
    return Task("gripper-task", hand, _object(), contacts, ("left", "right"))


# -- comparison helpers -----------------------------------------------------------------
def _assert_same_region(a, b):
    assert type(a) is type(b)
    params = a.seed_params(3)
    for x, y in zip(a.evaluate(params), b.evaluate(params)):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
    for x, y in zip(a.param_bounds(), b.param_bounds()):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)


def _assert_same_task(t1: Task, t2: Task, rng):
    assert (t2.name, t2.description, t2.fingers) == (t1.name, t1.description, t1.fingers)
    assert [(c.name, c.hand_region, c.object_region) for c in t2.contacts] == [
        (c.name, c.hand_region, c.object_region) for c in t1.contacts
    ]
    assert dict(t2.idle_angles).keys() == dict(t1.idle_angles).keys()
    for k, v in t1.idle_angles.items():
        assert t2.idle_angles[k] == pytest.approx(v, abs=1e-12)
    h1, h2 = t1.hand, t2.hand
    assert (h2.name, h2.dof_names, h2.link_names) == (h1.name, h1.dof_names, h1.link_names)
    np.testing.assert_allclose(h2.lower, h1.lower, rtol=0, atol=1e-12)
    np.testing.assert_allclose(h2.upper, h1.upper, rtol=0, atol=1e-12)
    assert [(c.dof, c.source) for c in h2.couplings] == [(c.dof, c.source) for c in h1.couplings]
    for c1, c2 in zip(h1.couplings, h2.couplings):
        assert (c2.ratio, c2.offset) == pytest.approx((c1.ratio, c1.offset), abs=1e-12)
    q = random_angles(h1, rng, 20)
    p1, p2 = forward_kinematics(h1, q), forward_kinematics(h2, q)
    np.testing.assert_allclose(p2.R_palm_link, p1.R_palm_link, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p2.r_palm_link, p1.r_palm_link, rtol=0, atol=1e-12)
    assert set(h2.regions) == set(h1.regions)
    for name, r in h1.regions.items():
        assert h2.regions[name].link == r.link
        _assert_same_region(r.region, h2.regions[name].region)
    assert set(t2.object.regions) == set(t1.object.regions)
    for name, r in t1.object.regions.items():
        _assert_same_region(r, t2.object.regions[name])
    assert t2.object.primitives == t1.object.primitives


def _close(a, b, tol):
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float):
        return isinstance(b, float) and abs(a - b) <= tol
    return a == b


def _assert_plain(value):
    """Only YAML-safe plain Python types."""
    if isinstance(value, dict):
        for k, v in value.items():
            assert type(k) is str
            _assert_plain(v)
    elif isinstance(value, list):
        for v in value:
            _assert_plain(v)
    else:
        assert type(value) in (str, float, int, bool), type(value)


# -- loading ----------------------------------------------------------------------------
SMALL_TASK = """\
prehension: task/1
name: knob-pinch
description: pinch a knob
hand: schunk-sa
hand_limits_deg:
  index_mcp_abd: [-22.5, 22.5]
hand_regions:
  index_tip: {link: index_distal, sphere_cap: {center: [20, 10, 0], radius: 13, axis: [0.14, 0, 0.99], half_angle_deg: 60}}
object:
  name: knob
  regions:
    knob_index: {bezier: [[[0, 0, 0], [0, 10, 0]], [[10, 0, 0], [10, 10, 2]]]}
    rim: {point: [1, 2, 3], normal: [0, 0, 2]}
    bump: {sphere_cap: {center: [0, 0, 30], radius: 5, axis: [0, 0, 1], half_angle_deg: 45}}
  display:
    primitives:
      - {box: {center: [0, 0, 0], size: [10, 20, 30]}}
      - {cylinder: {start: [0, 0, 0], end: [0, 0, 5], radius: 5, end_radius: 3}}
contacts:
  - {hand: index_tip, object: knob_index}
  - {name: thumb-rim, hand: thumb_tip, object: rim}
  - {hand: palm, object: bump}
fingers: [index, thumb]
idle_angles_deg: {ring_mcp_flex: 10}
"""


def test_load_small_task_fields_and_units():
    task = loads_task(SMALL_TASK)
    assert task.name == "knob-pinch" and task.description == "pinch a knob"
    assert task.fingers == ("index", "thumb")
    assert [(c.name, c.hand_region, c.object_region) for c in task.contacts] == [
        ("index_tip->knob_index", "index_tip", "knob_index"),
        ("thumb-rim", "thumb_tip", "rim"),
        ("palm->bump", "palm", "bump"),
    ]
    hand = task.hand
    assert hand.name == "schunk-sa"
    k = hand.dof_index("index_mcp_abd")
    assert (hand.lower[k], hand.upper[k]) == (pytest.approx(-math.pi / 8), pytest.approx(math.pi / 8))
    sa = schunk_sa_hand()
    j = hand.dof_index("ring_mcp_abd")
    assert (hand.lower[j], hand.upper[j]) == (sa.lower[j], sa.upper[j])  # untouched limits
    assert len(hand.couplings) == 4
    tip = hand.regions["index_tip"]
    assert tip.link == "index_distal"
    assert isinstance(tip.region, SphereCap)
    np.testing.assert_array_equal(tip.region.center, [20.0, 10.0, 0.0])
    assert tip.region.half_angle == pytest.approx(math.pi / 3, abs=1e-15)
    np.testing.assert_allclose(tip.region.axis, np.array([0.14, 0, 0.99]) / np.hypot(0.14, 0.99), atol=1e-15)
    assert task.idle_angles == {"ring_mcp_flex": pytest.approx(RAD(10), abs=1e-15)}

    regions = task.object.regions
    assert isinstance(regions["knob_index"], BezierRegion)
    assert regions["knob_index"].patch.control_points.shape == (2, 2, 3)
    np.testing.assert_array_equal(regions["knob_index"].patch.control_points[1, 1], [10.0, 10.0, 2.0])
    assert isinstance(regions["rim"], PointRegion)
    np.testing.assert_array_equal(regions["rim"].point, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(regions["rim"].normal, [0.0, 0.0, 1.0])
    bump = regions["bump"]
    assert isinstance(bump, SphereCap) and bump.radius == 5.0
    assert bump.half_angle == pytest.approx(math.pi / 4, abs=1e-15)
    assert task.object.primitives == (
        Box((0.0, 0.0, 0.0), (10.0, 20.0, 30.0)),
        Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 5.0), 5.0, end_radius=3.0),
    )
    assert task.object.mesh_file is None


def test_load_task_from_file_and_docs_example(tmp_path):
    path = tmp_path / "task.yaml"
    path.write_text(SMALL_TASK, encoding="utf-8")
    task = load_task(path)
    assert task.name == "knob-pinch"
    blocks = re.findall(r"```yaml\n(.*?)```", DOCS.read_text(encoding="utf-8"), re.S)
    assert len(blocks) == 3  # a task, a hand file reference, an inline hand
    doc_task = loads_task(blocks[0], source=str(DOCS))
    assert doc_task.name == "mug-pinch" and len(doc_task.contacts) == 2
    _, normal = doc_task.object.regions["handle_left"].evaluate([[0.5, 0.5]])
    np.testing.assert_allclose(normal[0] / np.linalg.norm(normal[0]), [0.0, 1.0, 0.0], atol=0.05)  # +y, as the comment says
    from prehension import solve

    result = solve(doc_task, "local")  # the example is a grasp that exists, penetration-free
    assert result.status == "solved", result.message
    from prehension.tasks.format.hand_files import HandFileSpec

    reference = HandFileSpec.model_validate(yaml.safe_load(blocks[1])["hand"])  # the schema takes it
    assert reference.fingertips["index"].half_angle_deg == 45
    doc_hand = hand_from_dict(yaml.safe_load(blocks[2]), source="docs")
    assert doc_hand.dof_names == ("left_abd", "left_flex", "right_flex")
    assert doc_hand.opposing_finger == "left" and doc_hand.frames["left_tip_frame"].link == "left"
    assert doc_hand.links[1].collision[0].a.tolist() == doc_hand.links[1].collision[0].b.tolist() == [30.0, 0.0, 0.0]


# -- round trips ------------------------------------------------------------------------
def test_round_trip_sa_hand_with_modified_limits_regions_and_no_couplings(rng):
    task = _sa_modified_task()
    d1 = task_to_dict(task)
    _assert_plain(d1)
    assert d1["prehension"] == FORMAT_TAG
    assert d1["hand"] == "schunk-sa"
    assert d1["hand_limits_deg"] == {"index_mcp_abd": [-22.5, 22.5], "thumb_base": [10.0, 80.0]}
    assert d1["hand_couplings"] is False
    assert set(d1["hand_regions"]) == {"index_tip", "index_pad"}  # new or changed only
    assert d1["hand_regions"]["index_tip"]["sphere_cap"]["half_angle_deg"] == 75.0
    assert d1["idle_angles_deg"] == {"ring_mcp_flex": 10.0}
    assert d1["contacts"][1] == {"name": "thumb-bump", "hand": "thumb_tip", "object": "bump"}
    assert d1["contacts"][0] == {"hand": "index_tip", "object": "face"}

    task2 = task_from_dict(d1)
    assert task_to_dict(task2) == d1
    _assert_same_task(task, task2, rng)
    task3 = loads_task(dumps_task(task))  # through YAML text as well
    assert task_to_dict(task3) == d1
    _assert_same_task(task, task3, rng)


def test_unmodified_sa_hand_is_written_by_name_only():
    sa = schunk_sa_hand()
    task = Task("plain", sa, _object(), (Contact("index_tip", "face"),), ("index",))
    d = task_to_dict(task)
    assert d["hand"] == "schunk-sa"
    assert not {"hand_limits_deg", "hand_couplings", "hand_regions"} & set(d)
    assert task_to_dict(task_from_dict(d)) == d


def test_sa_hand_with_changed_geometry_is_written_inline(rng):
    sa = schunk_sa_hand()
    links = (Link("palm"),) + sa.links[1:]  # no palm collision shapes: not the built-in any more
    hand = Hand(sa.name, links, sa.joints, sa.couplings, sa.fingers, sa.regions, sa.collision_exclusions)
    task = Task("changed", hand, _object(), (Contact("index_tip", "face"),), ("index",))
    d1 = task_to_dict(task)
    assert isinstance(d1["hand"], dict) and d1["hand"]["name"] == "schunk-sa"
    assert d1["hand"]["links"][0] == {"name": "palm"}
    task2 = task_from_dict(d1)
    _assert_same_task(task, task2, rng)
    assert task_to_dict(task2) == d1


def test_round_trip_inline_custom_hand(rng):
    task = _custom_task()
    d1 = task_to_dict(task)
    _assert_plain(d1)
    hand = d1["hand"]
    assert isinstance(hand, dict) and hand["name"] == "gripper"
    assert hand["links"][0]["collision"][1] == {"center": [0.0, 0.0, 20.0], "radius": 9.0}  # a sphere
    joint = hand["joints"][1]
    assert joint["origin_in_child"] == [-2.0, 0.0, 0.5]
    assert joint["axis_in_parent"] == pytest.approx([0.0, 0.6, 0.8], abs=1e-15)
    assert "rotation_zero" not in joint and "axis_in_child" not in joint
    assert hand["joints"][0]["rotation_zero"] == [list(r) for r in PERMUTATION]
    assert hand["couplings"] == [{"angle": "left_tip", "source": "left_flex", "ratio": 0.75, "offset_deg": 5.0}]
    assert hand["collision_exclusions"] == [["left_dist", "right"]]
    assert hand["fingers"][0] == {"name": "left", "links": ["left_prox", "left_dist"]}
    assert d1["object"]["display"]["primitives"][2] == {
        "ellipsoid": {"center": [0.0, 0.0, 5.0], "radii": [3.0, 4.0, 5.0], "resolution": 12}
    }

    task2 = task_from_dict(d1)
    assert task_to_dict(task2) == d1
    _assert_same_task(task, task2, rng)
    task3 = loads_task(dumps_task(task2))
    assert task_to_dict(task3) == d1
    _assert_same_task(task, task3, rng)


def test_round_trip_inline_hand_with_general_rotation(rng):
    R = rotation_about(np.array([0.3, -0.5, 0.8]), 0.7)
    task = _custom_task(_custom_hand(tip_rotation=R))
    d1 = task_to_dict(task)
    task2 = task_from_dict(d1)
    _assert_same_task(task, task2, rng)
    np.testing.assert_allclose(task2.hand.joints[1].R_parent_child_zero, R, rtol=0, atol=1e-15)
    d2 = task_to_dict(task2)
    assert d2 == d1


def test_hand_and_region_dict_round_trips(rng):
    hand = _custom_hand()
    hd = hand_to_dict(hand)
    _assert_plain(hd)
    again = hand_from_dict(hd, source="h")
    assert hand_to_dict(again) == hd
    q = random_angles(hand, rng, 10)
    np.testing.assert_allclose(
        forward_kinematics(again, q).r_palm_link, forward_kinematics(hand, q).r_palm_link, rtol=0, atol=1e-12
    )
    for region in _object().regions.values():
        rd = region_to_dict(region)
        _assert_plain(rd)
        back = region_from_dict(rd, "here")
        _assert_same_region(region, back)
        assert region_to_dict(back) == rd
    with pytest.raises(InvalidTask, match=r"^here: sphere_cap.radius: must be greater than 0"):
        region_from_dict({"sphere_cap": {"center": [0, 0, 0], "radius": 0, "axis": [0, 0, 1], "half_angle_deg": 5}}, "here")
    with pytest.raises(InvalidTask, match=r"^here: give exactly one of bezier, sphere_cap, point$"):
        region_from_dict({}, "here")


def test_builtin_hands_table_and_primitive_schema_match_meshes():
    assert FORMAT_TAG == "task/1"
    assert list(BUILTIN_HANDS) == ["schunk-sa", "schunk-sa-enclosing"]
    assert BUILTIN_HANDS["schunk-sa"]().n_dof == 17
    assert BUILTIN_HANDS["schunk-sa-enclosing"]().dof_names == BUILTIN_HANDS["schunk-sa"]().dof_names
    for key, (spec, cls) in PRIMITIVES.items():
        assert set(spec.model_fields) == {f.name for f in dataclasses.fields(cls)}, key


def test_dumps_task_is_readable_yaml():
    text = dumps_task(_sa_modified_task())
    assert text.startswith("prehension: task/1\nname: sa-modified\n")
    assert "hand: schunk-sa\n" in text
    assert "  index_mcp_abd: [-22.5, 22.5]\n" in text or "hand_limits_deg: {index_mcp_abd: [-22.5, 22.5]" in text
    assert "- {hand: index_tip, object: face}\n" in text
    assert yaml.safe_load(text) == task_to_dict(_sa_modified_task())


# -- files: hand files, mesh files, atomic writes -----------------------------------------
def test_hand_file_reference(tmp_path, rng):
    (tmp_path / "hands").mkdir()
    (tmp_path / "hands" / "gripper.yaml").write_text(yaml.safe_dump(hand_to_dict(_custom_hand())), encoding="utf-8")
    text = dumps_task(_custom_task()).replace("hand:\n", "hand_was_inline:\n", 1)
    data = yaml.safe_load(text)
    data.pop("hand_was_inline")
    data = {"prehension": data.pop("prehension"), "name": data.pop("name"), "hand": {"file": "hands/gripper.yaml"}, **data}
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    task = load_task(path)
    _assert_same_task(_custom_task(), task, rng)
    assert task_to_dict(task, base_dir=tmp_path)["hand"] == {"file": "hands/gripper.yaml"}  # written back as named
    inline = task_to_dict(task, hand_inline=True)["hand"]  # as in result files: the hand and where it came from
    assert inline.pop("source")["path"] == str((tmp_path / "hands" / "gripper.yaml").resolve())
    assert inline == hand_to_dict(_custom_hand())

    (tmp_path / "hands" / "gripper.yaml").write_text("name: g\nlinks: []\n", encoding="utf-8")
    with pytest.raises(InvalidTask, match=r"hand\.file: .*gripper\.yaml: links: needs at least 1 item") as info:
        load_task(path)
    assert str(info.value).startswith(f"{path}: hand.file: ")


def test_mesh_file_is_resolved_and_written_relative(tmp_path):
    (tmp_path / "meshes").mkdir()
    mesh = tmp_path / "meshes" / "knob.off"
    mesh.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", encoding="utf-8")
    text = SMALL_TASK.replace("  display:\n", "  display:\n    mesh_file: meshes/knob.off\n")
    path = tmp_path / "task.yaml"
    path.write_text(text, encoding="utf-8")
    task = load_task(path)
    assert task.object.mesh_file == str(mesh.resolve())
    assert task.object.display_mesh().faces.shape == (1, 3)
    dump_task(task, tmp_path / "copy.yaml")
    assert "mesh_file: meshes/knob.off\n" in (tmp_path / "copy.yaml").read_text()
    (tmp_path / "sub").mkdir()
    dump_task(task, tmp_path / "sub" / "copy.yaml")
    assert "mesh_file: ../meshes/knob.off\n" in (tmp_path / "sub" / "copy.yaml").read_text()
    assert load_task(tmp_path / "sub" / "copy.yaml").object.mesh_file == str(mesh.resolve())
    assert task_to_dict(task)["object"]["display"]["mesh_file"] == str(mesh.resolve())  # no base_dir: absolute


def test_dump_task_writes_and_replaces_atomically(tmp_path, monkeypatch, rng):
    path = tmp_path / "task.yaml"
    path.write_text("old: content\n", encoding="utf-8")
    os.chmod(path, 0o640)
    task = _sa_modified_task()
    dump_task(task, path)
    assert os.listdir(tmp_path) == ["task.yaml"]
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o640  # permissions of the replaced file kept
    _assert_same_task(task, load_task(path), rng)
    written = path.read_text(encoding="utf-8")
    assert written == dumps_task(task, base_dir=tmp_path)

    other = _custom_task()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    for target in ("replace", "fsync"):  # fail after the temporary file was written / mid-write
        with monkeypatch.context() as m:
            m.setattr(os, target, boom)
            with pytest.raises(OSError, match="disk full"):
                dump_task(other, path)
        assert path.read_text(encoding="utf-8") == written
        assert os.listdir(tmp_path) == ["task.yaml"]
    with monkeypatch.context() as m:
        m.setattr(yaml, "dump", boom)
        with pytest.raises(OSError, match="disk full"):
            dump_task(other, path)
    assert path.read_text(encoding="utf-8") == written
    assert os.listdir(tmp_path) == ["task.yaml"]

    dump_task(other, tmp_path / "new.yaml")  # a new file
    assert sorted(os.listdir(tmp_path)) == ["new.yaml", "task.yaml"]
    assert task_to_dict(load_task(tmp_path / "new.yaml")) == task_to_dict(other)


# -- bad files --------------------------------------------------------------------------
GOOD = """\
prehension: task/1
name: bad-task
hand: schunk-sa
object:
  name: knob
  regions:
    knob: {bezier: [[[0, 0, 0], [0, 10, 0]], [[10, 0, 0], [10, 10, 0]]]}
    bump: {sphere_cap: {center: [0, 0, 0], radius: 5, axis: [0, 0, 1], half_angle_deg: 60}}
contacts:
  - {hand: index_tip, object: knob}
  - {hand: thumb_tip, object: bump}
fingers: [index, thumb]
"""

INLINE_HAND_ONE_ANGLE = """\
hand:
  name: broken
  links: [{name: palm}, {name: f}]
  joints:
    - {name: j, type: universal, parent: palm, child: f, origin_in_parent: [0, 0, 0],
       axis_in_parent: [1, 0, 0], axis_in_child: [0, 1, 0], angles: [{name: a, lower_deg: 0, upper_deg: 9}]}
"""

BAD_CASES = {
    "wrong tag": (("prehension: task/1", "prehension: task/2"),
                  r"prehension: unsupported format tag 'task/2'; the supported tag is 'task/1'"),
    "missing tag": (("prehension: task/1\n", ""), r"prehension: missing format tag; .*'prehension: task/1'"),
    "unknown built-in hand": (("hand: schunk-sa", "hand: shunk-sa"),
                              r"hand: unknown built-in hand 'shunk-sa'; built-in hands are: schunk-sa"),
    "hand of wrong type": (("hand: schunk-sa", "hand: [1, 2]"), r"hand: give a built-in hand name \(schunk-sa, schunk-sa-enclosing\)"),
    "misspelt key": (("  name: knob\n", "  name: knob\n  colour: red\n"),
                     r"object: extra key 'colour' not allowed here; allowed keys: name, regions, mesh, scale, units, shape, collisions, surface_tolerance_mm, display"),
    "misspelt top-level key": (("fingers:", "finger:"), r"extra key 'finger' not allowed .*did you mean 'fingers'"),
    "missing contacts": (("contacts:\n  - {hand: index_tip, object: knob}\n  - {hand: thumb_tip, object: bump}\n", ""),
                         r"bad\.yaml: contacts: field required"),
    "empty contacts": (("contacts:\n  - {hand: index_tip, object: knob}\n  - {hand: thumb_tip, object: bump}\n",
                        "contacts: []\n"), r"contacts: needs at least 1 item\(s\), got 0"),
    "contact without hand": (("{hand: index_tip, object: knob}", "{object: knob}"), r"contacts\.0\.hand: field required"),
    "unknown hand region": (("{hand: index_tip,", "{hand: pinky_tip,"),
                            r"contacts\.0\.hand: hand region 'pinky_tip' not found; regions are: ring_tip, middle_tip, "
                            r"index_tip, thumb_tip, palm"),
    "unknown object region": (("object: bump}", "object: bunp}"),
                              r"contacts\.1\.object: object region 'bunp' not found on 'knob'; regions are: knob, bump"),
    "unknown finger": (("[index, thumb]", "[index, pinky]"),
                       r"fingers\.1: finger 'pinky' not found; fingers are: ring, middle, index, thumb"),
    "finger not taking part": (("[index, thumb]", "[index]"), r"task 'bad-task': contact 'thumb_tip->bump' .*does not take part"),
    "degenerate patch": (("[[10, 0, 0], [10, 10, 0]]", "[[0, 0, 0], [10, 10, 0]]"),
                         r"object\.regions\.knob: Bézier patch normal p_u x p_v (vanishes|could not be shown)"),
    "ragged control net": (("[[10, 0, 0], [10, 10, 0]]", "[[10, 0, 0]]"),
                           r"object\.regions\.knob\.bezier: control net is ragged: row 0 has 2 points but row 1 has 1"),
    "two region kinds": (("knob: {bezier:", "knob: {point: [0, 0, 0], normal: [0, 0, 1], bezier:"),
                         r"object\.regions\.knob: give exactly one of bezier, sphere_cap, point \(got bezier, point\)"),
    "no region kind": (("knob: {bezier: [[[0, 0, 0], [0, 10, 0]], [[10, 0, 0], [10, 10, 0]]]}", "knob: {}"),
                       r"object\.regions\.knob: give exactly one of bezier, sphere_cap, point$"),
    "negative radius": (("radius: 5,", "radius: -5,"),
                        r"object\.regions\.bump\.sphere_cap\.radius: must be greater than 0 \(got -5"),
    "half angle too big": (("half_angle_deg: 60", "half_angle_deg: 200"),
                           r"object\.regions\.bump\.sphere_cap\.half_angle_deg: must be less than or equal to 180"),
    "short vector": (("center: [0, 0, 0]", "center: [0, 0]"),
                     r"object\.regions\.bump\.sphere_cap\.center: expected a list of 3 numbers \[x, y, z\], got \[0, 0\]"),
    "text for a number": (("radius: 5,", "radius: five,"),
                          r"object\.regions\.bump\.sphere_cap\.radius: must be a valid number \(got 'five'\)"),
    "zero axis": (("axis: [0, 0, 1]", "axis: [0, 0, 0]"), r"object\.regions\.bump: sphere cap axis must be a non-zero vector"),
    "universal joint with one angle": (("hand: schunk-sa\n", INLINE_HAND_ONE_ANGLE),
                                       r"hand\.joints\.0: a universal joint has 2 angle\(s\); got 1 in 'angles'"),
    "limits for unknown angle": (("hand: schunk-sa\n", "hand: schunk-sa\nhand_limits_deg: {pinky_mcp_abd: [-10, 10]}\n"),
                                 r"hand_limits_deg\.pinky_mcp_abd: unknown joint angle 'pinky_mcp_abd'; angles of "
                                 r"'schunk-sa' are: ring_mcp_abd, ring_mcp_flex"),
    "limits reversed": (("hand: schunk-sa\n", "hand: schunk-sa\nhand_limits_deg: {ring_pip: [50, 10]}\n"),
                        r"hand_limits_deg\.ring_pip: lower limit 50\.0 exceeds upper limit 10\.0"),
    "hand region on unknown link": (("hand: schunk-sa\n", "hand: schunk-sa\nhand_regions: "
                                     "{x: {link: nowhere, point: [0, 0, 0], normal: [0, 0, 1]}}\n"),
                                    r"hand_regions\.x\.link: link 'nowhere' not found; links are: palm, ring_proximal"),
    "idle angle outside limits": (("fingers: [index, thumb]\n", "fingers: [index, thumb]\nidle_angles_deg: {ring_pip: 90}\n"),
                                  r"idle_angles_deg\.ring_pip: 90\.0 deg is outside the limits \[4, 75\] deg"),
    "idle angle unknown": (("fingers: [index, thumb]\n", "fingers: [index, thumb]\nidle_angles_deg: {pinky: 9}\n"),
                           r"idle_angles_deg\.pinky: joint angle 'pinky' not found; angles are: ring_mcp_abd"),
    "missing hand file": (("hand: schunk-sa", "hand: {file: nope.yaml}"), r"hand\.file: .*nope\.yaml: cannot read the file"),
    "missing mesh file": (("  regions:\n", "  display: {mesh_file: nope.off}\n  regions:\n"),
                          r"object\.display\.mesh_file: mesh file not found: .*nope\.off"),
    "bad primitive": (("  regions:\n", "  display: {primitives: [{cone: {radius: 1}}]}\n  regions:\n"),
                      r"object\.display\.primitives\.0: extra key 'cone' not allowed here; allowed keys: box, sphere"),
    "zero-length cylinder": (("  regions:\n", "  display: {primitives: [{cylinder: {start: [0, 0, 0], end: [0, 0, 0], "
                              "radius: 1}}]}\n  regions:\n"),
                             r"object\.display\.primitives\.0\.cylinder: cylinder start and end must differ"),
    "duplicate key": (("name: bad-task\n", "name: bad-task\nname: again\n"), r"not valid YAML \(line 3\): duplicate key 'name'"),
    "yaml syntax error": (("hand: schunk-sa\n", "hand: schunk-sa: extra\n"),
                          r"not valid YAML \(line 3\): mapping values are not allowed here"),
    "unclosed bracket": (("fingers: [index, thumb]\n", "fingers: [index, thumb\n"), r"not valid YAML \(line \d+\)"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_task_files(tmp_path, case):
    (old, new), match = BAD_CASES[case]
    assert old in GOOD or old in INLINE_HAND_ONE_ANGLE
    path = tmp_path / "bad.yaml"
    path.write_text(GOOD.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(InvalidTask, match=match) as info:
        load_task(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "pydantic" not in message.lower() and "errors.pydantic.dev" not in message
    assert "Traceback" not in message and "Value error" not in message


@pytest.mark.parametrize(
    "text, match",
    [
        ("", r"bad\.yaml: the file is empty; a task file is a mapping that starts with 'prehension: task/1'"),
        ("- a\n- b\n", r"bad\.yaml: the top level must be a mapping \(key: value pairs\), got a list"),
        ("just text\n", r"bad\.yaml: the top level must be a mapping \(key: value pairs\), got a string"),
    ],
)
def test_empty_or_non_mapping_files(tmp_path, text, match):
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InvalidTask, match=match):
        load_task(path)


def test_dict_sources_and_missing_file(tmp_path):
    with pytest.raises(InvalidTask, match=r"^<dict>: the top level must be a mapping"):
        task_from_dict([1, 2])
    with pytest.raises(InvalidTask, match=r"^mine: name: field required"):
        task_from_dict({"prehension": "task/1"} | {k: v for k, v in yaml.safe_load(GOOD).items() if k != "name"}, source="mine")
    with pytest.raises(InvalidTask, match=r"^<string>: not valid YAML \(line 1\)"):
        loads_task("a: [")
    with pytest.raises(InvalidTask, match=r"nothing\.yaml: cannot read the file"):
        load_task(tmp_path / "nothing.yaml")
    with pytest.raises(InvalidTask, match=r"^h: links\.0\.collision\.0: give either a, b and radius"):
        hand_from_dict({"name": "h", "links": [{"name": "palm", "collision": [{"a": [0, 0, 0], "radius": 1}]}]}, "h")
    with pytest.raises(InvalidTask, match=r"^h: joint 'j': parent link 'nowhere' not found; links are: palm, f"):
        hand_from_dict({"name": "h", "links": [{"name": "palm"}, {"name": "f"}], "joints": [
            {"name": "j", "type": "revolute", "parent": "nowhere", "child": "f", "origin_in_parent": [0, 0, 0],
             "axis_in_parent": [1, 0, 0], "angles": [{"name": "a", "lower_deg": 0, "upper_deg": 9}]}]}, "h")
