"""CuikSuite .world import: semantics against the built-in SA hand, errors on bad files."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CUIK_DIR, cuik_worlds, requires_cuik
from prehension.errors import WorldFileError
from prehension.hands.kinematics import forward_kinematics
from prehension.paper import CUIK_FILE_TASKS
from prehension.tasks.cuik_import import import_world, task_from_world
from prehension.tasks.cuik_parser import parse_world
from prehension.tasks.library import load_builtin_task
from prehension.tasks.yaml_io import dumps_task, loads_task, task_to_dict

# The files' link and angle names -> the built-in SA hand's.
LINKS = {
    "p12": "ring_proximal", "p13": "ring_middle", "p14": "ring_distal",
    "p22": "middle_proximal", "p23": "middle_middle", "p24": "middle_distal",
    "p32": "index_proximal", "p33": "index_middle", "p34": "index_distal",
    "p40": "thumb_base", "p42": "thumb_proximal", "p43": "thumb_middle", "p44": "thumb_distal",
}  # fmt: skip
ANGLES = {"_1": "_mcp_abd", "_2": "_mcp_flex"}
FINGER = {"1": "ring", "2": "middle", "3": "index", "4": "thumb"}


def _builtin_angle(file_angle: str) -> str:
    finger = FINGER[file_angle[1]]
    if file_angle == "p40":
        return "thumb_base"
    if file_angle[2] == "2":
        return finger + ANGLES[file_angle[3:]]
    return finger + {"3": "_pip", "4": "_dip"}[file_angle[2]]


def _key(path) -> str:
    return f"{path.parent.parent.name}/{path.parent.name}"


@requires_cuik
@pytest.mark.parametrize("path", cuik_worlds(), ids=_key)
def test_world_hand_moves_like_the_builtin_sa_hand(path, sa_hand, rng):
    """Same angles, same link poses: the importer's reading of the file (2011 angle-2 sign)
    and the built-in hand (Table 3 cross-checked with the files) agree.  The files round
    the thumb's first axis (cos 55, 0, sin 55) to 5 digits, hence 1e-3 mm."""
    task = import_world(path)
    hand = task.hand
    q_sa = rng.uniform(-1.0, 1.0, size=(8, sa_hand.n_dof))
    q_file = np.stack([q_sa[:, sa_hand.dof_index(_builtin_angle(d))] for d in hand.dof_names], axis=1)
    T_sa = forward_kinematics(sa_hand, q_sa).T_palm_link
    T_file = forward_kinematics(hand, q_file).T_palm_link
    for file_link, sa_link in LINKS.items():
        np.testing.assert_allclose(
            T_file[:, hand.link_index(file_link)], T_sa[:, sa_hand.link_index(sa_link)], atol=1e-3
        )


@requires_cuik
@pytest.mark.parametrize("path", cuik_worlds(), ids=_key)
def test_builtin_task_reproduces_the_file_numbers(path):
    imported = import_world(path)
    builtin = load_builtin_task(CUIK_FILE_TASKS[_key(path)])
    assert len(builtin.contacts) == len(imported.contacts)
    for c_file, c_ours in zip(imported.contacts, builtin.contacts):
        r_file, r_ours = imported.hand_region(c_file), builtin.hand_region(c_ours)
        assert LINKS.get(r_file.link, r_file.link) == r_ours.link
        for attr in ("center", "radius", "axis", "half_angle"):
            np.testing.assert_allclose(getattr(r_ours.region, attr), getattr(r_file.region, attr), atol=1e-12)
        np.testing.assert_allclose(
            builtin.object_region(c_ours).patch.control_points,
            imported.object_region(c_file).patch.control_points,
            atol=1e-12,
        )
    fingers = {LINKS[f.tip_link].split("_")[0] for f in imported.hand.fingers if f.name in imported.fingers}
    assert fingers == set(builtin.fingers)


@requires_cuik
def test_imported_object_normals_point_out_of_the_object():
    """Lid lifting: the knob patches lie at z = -15 and z = +15 around the knob axis (y):
    outward normals must point away from it (the file's own p_u x p_v points inwards)."""
    task = import_world(CUIK_DIR / "teapot/2_contacts_index_thumb/SAHandplusTeapot.world")
    for c in task.contacts:
        point, normal = task.object_region(c).evaluate(np.array([[0.5, 0.5]]))
        assert np.sign(normal[0, 2]) == np.sign(point[0, 2]) != 0


@requires_cuik
@pytest.mark.parametrize("path", cuik_worlds(), ids=_key)
def test_imported_task_round_trips_through_yaml(path):
    for couple in (False, True):
        task = import_world(path, couple_distal=couple)
        again = loads_task(dumps_task(task))
        assert task_to_dict(again) == task_to_dict(task)
        assert len(again.hand.couplings) == (4 if couple else 0)


@requires_cuik
def test_angle2_reading_changes_the_flexion_side():
    path = CUIK_DIR / "teapot/2_contacts_index_thumb/SAHandplusTeapot.world"
    old, new = import_world(path), import_world(path, angle2="current")
    q = np.zeros(old.hand.n_dof)
    q[old.hand.dof_index("p32_2")] = 0.5
    x_old = forward_kinematics(old.hand, q).R_palm_link[0, old.hand.link_index("p32")][:, 0]
    x_new = forward_kinematics(new.hand, q).R_palm_link[0, new.hand.link_index("p32")][:, 0]
    assert x_old[0] > 0.4 and x_new[0] < -0.4  # 2011: towards the palm's front (+x)


WORLD_HEAD = """
[CONSTANTS]
r := 10
[LINKS]
palm
f1
X_1
obj
[JOINTS]
revolute: palm (0,0,100)+(0,1,0) f1 (0,0,0)+(0,1,0) range [0,pi/2] +(0,0,1) +(1,0,0)
"""


def _import_text(text):
    return task_from_world(parse_world(text, path="t.world"))


def test_small_world_imports_and_names_things():
    text = WORLD_HEAD + """
SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)
in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)
"""
    task = _import_text(text)
    assert task.hand.dof_names == ("f1",)
    assert task.fingers == ("f1",)
    region = task.hand_region(task.contacts[0]).region
    assert region.radius == 10 and region.half_angle == pytest.approx(np.pi / 3)
    _, normal = task.object_region(task.contacts[0]).evaluate(np.array([[0.5, 0.5]]))
    np.testing.assert_allclose(normal, [[0, 0, -1]], atol=1e-12)  # minus the file's p_u x p_v


@pytest.mark.parametrize(
    "extra, message",
    [
        ("SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n", r"t.world:\d+: SPHERICAL joint to 'X_1' has no in_patch"),
        (
            "SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n"
            "in_patch: X_1 (0,0,0) (0,0,1) f1 (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n",
            r"t.world:\d+: in_patch: the patch must lie on the object",
        ),
        (
            "SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n"
            "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,0,0) (10,0,0) (10,10,0)\n",
            r"t.world:\d+: in_patch: .*vanishes",
        ),
        (
            "SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(1,0,0)\n"
            "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n",
            r"t.world:\d+: SPHERICAL contact: the contact-frame point must be",
        ),
        ("", r"t.world: the file states no contact \(no in_patch joint\)"),
    ],
)
def test_bad_worlds_get_errors_naming_the_line(extra, message):
    with pytest.raises(WorldFileError, match=message):
        _import_text(WORLD_HEAD + extra)


def test_loose_link_is_refused_with_its_line():
    text = WORLD_HEAD.replace("obj\n", "obj\njunk\n") + (
        "SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n"
        "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n"
    )
    with pytest.raises(WorldFileError, match=r"t.world:9: link 'junk' is connected to nothing"):
        _import_text(text)


def test_reference_vector_not_orthogonal_to_axis_is_refused():
    text = WORLD_HEAD.replace("+(0,0,1) +(1,0,0)", "+(0,1,0) +(1,0,0)") + (
        "SPHERICAL: f1 (50,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n"
        "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n"
    )
    with pytest.raises(WorldFileError, match=r"t.world:\d+: revolute joint: the first reference vector must be orthogonal"):
        _import_text(text)


def test_unsupported_joint_kind_names_the_line():
    with pytest.raises(WorldFileError, match=r"t.world:\d+: prismatic joint between 'palm' and 'f1': prehension's hands "
                       r"have revolute and universal joints only"):
        _import_text(WORLD_HEAD + "prismatic: palm (0,0,0)+(1,0,0) f1 (0,0,0)+(1,0,0) range [0, 1]\n")


@requires_cuik
def test_the_objects_body_file_is_its_collision_solid_when_closed_else_the_reason_is_stated():
    """The scalpel's body file is closed: the imported task collides with it (and keeps it
    through a task file); the teapot's is open: display only, and the description says
    why.  Both say what judged the hand."""
    from prehension.objects.solid import MeshFileSolid

    scalpel = import_world(next(p for p in cuik_worlds() if "scalpel" in str(p)))
    assert isinstance(scalpel.object.solid, MeshFileSolid) and scalpel.object.collides
    assert scalpel.object.solid.path.endswith("scalpel.off")
    assert "object collisions: its body file scalpel.off" in scalpel.description
    assert "hand collisions: the built-in SA hand's capsules" in scalpel.description
    teapot = import_world(next(p for p in cuik_worlds() if "teapot" in str(p)))
    assert teapot.object.solid is None and not teapot.object.collides and teapot.object.mesh_file.endswith("teapot.off")
    assert "teapot.off is display only, not a collision solid, because mesh is not watertight (304 edges" in teapot.description
    assert loads_task(dumps_task(scalpel)).object.collides  # the solid survives a task file


@requires_cuik
@pytest.mark.parametrize("path", cuik_worlds()[:1], ids=_key)
def test_a_world_of_the_sa_hand_gets_its_capsules_and_another_hand_none(path, sa_hand):
    """The IJRR files' hand moves as the SA hand: each link carries the SA link's capsules
    (matched by pose, so the file's names need not be ours); the 2011 angle reading read
    the other way moves differently: no capsules, and the notes say so."""
    from prehension.tasks.cuik_import import NO_HAND_GEOMETRY, SA_GEOMETRY

    hand = import_world(path).hand
    assert hand.notes[-1] == SA_GEOMETRY
    for file_link, sa_link in LINKS.items():
        ours, theirs = hand.links[hand.link_index(file_link)].collision, sa_hand.links[sa_hand.link_index(sa_link)].collision
        assert len(ours) == len(theirs) >= 1
        for a, b in zip(ours, theirs):
            assert np.allclose(a.a, b.a) and np.allclose(a.b, b.b) and a.radius == b.radius
    other = import_world(path, angle2="current").hand
    assert other.notes[-1] == NO_HAND_GEOMETRY and not any(link.collision for link in other.links)
