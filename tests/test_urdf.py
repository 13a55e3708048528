"""Reading hands from URDF: the shared public hands, fixed-joint merging, mimics, capsules, errors."""

from __future__ import annotations

import math
import struct
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import HANDS_DIR
from prehension.errors import InvalidHand
from prehension.hands.collision import capsule_clearances
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.enclosure import capsule_gaps
from prehension.hands.urdf import hand_from_urdf, load_urdf_hand, mesh_capsule, read_mesh_vertices

SVH = HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf"
ALLEGRO = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
requires_hands = pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")
SHARED = [pytest.param(SVH, id="svh"), pytest.param(ALLEGRO, id="allegro")]


# -- an independent URDF reader and forward kinematics (plain 4x4 chain, metres) -------------
def _origin(joint: ET.Element) -> np.ndarray:
    o = joint.find("origin")
    xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
    rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # extrinsic x, y, z = Rz Ry Rx
    T[:3, 3] = xyz
    return T


def _rot(axis, q) -> np.ndarray:
    T = np.eye(4)
    a = np.asarray(axis, dtype=float)
    T[:3, :3] = Rotation.from_rotvec(a / np.linalg.norm(a) * q).as_matrix()
    return T


def _file_joints(path) -> dict[str, ET.Element]:
    return {j.get("name"): j for j in ET.parse(path).getroot().findall("joint")}


def _movable(joints) -> dict[str, ET.Element]:
    return {n: j for n, j in joints.items() if j.get("type") in ("revolute", "continuous")}


def _file_angles(joints, rng) -> dict[str, float]:
    """Random angles of independent joints within the file's limits; mimics from the file."""
    q = {}
    for n, j in _movable(joints).items():
        lim = j.find("limit")
        q[n] = rng.uniform(float(lim.get("lower")), float(lim.get("upper")))

    def value(n):
        m = joints[n].find("mimic")
        if m is None:
            return q[n]
        return float(m.get("multiplier", 1)) * value(m.get("joint")) + float(m.get("offset", 0))

    return {n: value(n) for n in q}


def _reference_fk(joints, root: str, q: dict[str, float]) -> dict[str, np.ndarray]:
    """T_root_link (metres) of every link: T = T_parent * origin(xyz, rpy) * Rot(axis, q)."""
    T = {root: np.eye(4)}
    pending = list(joints.values())
    while pending:
        j = next(j for j in pending if j.find("parent").get("link") in T)
        pending.remove(j)
        Tj = T[j.find("parent").get("link")] @ _origin(j)
        if j.get("type") != "fixed":
            axis = j.find("axis")
            xyz = axis.get("xyz") if axis is not None else "1 0 0"  # URDF default axis
            Tj = Tj @ _rot([float(v) for v in xyz.split()], q[j.get("name")])
        T[j.find("child").get("link")] = Tj
    return T


# -- the shared hands ------------------------------------------------------------------------------
@requires_hands
@pytest.mark.parametrize("path", SHARED)
def test_shared_hand_dofs_limits_couplings(path):
    hand, warnings = load_urdf_hand(path)
    joints = _file_joints(path)
    movable = _movable(joints)
    assert warnings == []
    assert set(hand.dof_names) == set(movable)
    assert hand.n_dof == len(movable)
    for n, j in movable.items():
        i = hand.dof_index(n)
        assert hand.lower[i] == float(j.find("limit").get("lower"))
        assert hand.upper[i] == float(j.find("limit").get("upper"))
    mimics = {n: j.find("mimic") for n, j in movable.items() if j.find("mimic") is not None}
    assert {c.dof for c in hand.couplings} == set(mimics)
    for c in hand.couplings:  # neither shared hand chains its mimics
        assert c.source == mimics[c.dof].get("joint")
        assert c.ratio == float(mimics[c.dof].get("multiplier"))
        assert c.offset == float(mimics[c.dof].get("offset"))
    assert hand.palm == {"svh": "right_hand_e1", "allegro_right": "base_link"}[hand.name]  # where the fingers branch
    assert set(hand.regions) == {f"{f.name}_tip" for f in hand.fingers}  # one fingertip per finger, fitted


@requires_hands
def test_svh_and_allegro_counts():
    svh, allegro = hand_from_urdf(SVH), hand_from_urdf(ALLEGRO)
    assert (svh.name, svh.n_dof, len(svh.couplings)) == ("svh", 20, 11)
    assert (allegro.name, allegro.n_dof, len(allegro.couplings)) == ("allegro_right", 16, 0)
    for hand, path in ((svh, SVH), (allegro, ALLEGRO)):  # fixed joints merged: links - fixed joints survive
        root = ET.parse(path).getroot()
        n_fixed = sum(j.get("type") == "fixed" for j in root.findall("joint"))
        assert len(hand.links) == len(root.findall("link")) - n_fixed == 1 + hand.n_dof
    assert len(svh.links) == 21 and len(allegro.links) == 17
    assert [(f.name, f.links[0]) for f in allegro.fingers] == [
        ("index", "link_0.0"), ("middle", "link_4.0"), ("ring", "link_8.0"), ("thumb", "link_12.0"),
    ]  # fmt: skip
    assert all(len(f.links) == 4 for f in allegro.fingers)
    assert [(f.name, f.links[-1]) for f in svh.fingers] == [
        ("thumb", "right_hand_c"), ("index", "right_hand_t"), ("middle", "right_hand_s"), ("ring", "right_hand_r"),
        ("little", "right_hand_q"),
    ]  # fmt: skip
    assert svh.finger("middle").links == ("right_hand_k", "right_hand_o", "right_hand_s")
    assert svh.opposing_finger == allegro.opposing_finger == "thumb"
    # every link but the palm is in exactly one finger, but the SVH's second palm part
    # (it carries the ring and little fingers and moves with the thumb's opposition)
    for hand, palm_parts in ((svh, ["right_hand_e2"]), (allegro, [])):
        in_fingers = [link for f in hand.fingers for link in f.links]
        assert sorted(in_fingers + palm_parts) == sorted(hand.link_names[1:])
    assert svh.frames["fftip"].link == "right_hand_t"
    np.testing.assert_allclose(svh.frames["fftip"].origin, [14.0, 0.0, 0.0], atol=1e-12)


@requires_hands
@pytest.mark.parametrize("path", SHARED)
def test_fk_matches_independent_urdf_chain(path, rng):
    hand = hand_from_urdf(path)
    joints = _file_joints(path)
    for _ in range(10):
        q_file = _file_angles(joints, rng)
        q = np.array([q_file[d] for d in hand.dof_names])
        for c in hand.couplings:
            expected = c.ratio * q[hand.dof_index(c.source)] + c.offset
            assert q[hand.dof_index(c.dof)] == pytest.approx(expected, abs=1e-15)
        root = ET.parse(path).getroot().find("link").get("name")  # both files list their root first
        ref = _reference_fk(joints, root, q_file)  # T_root_link; the palm may lie below the root
        pose = forward_kinematics(hand, q)
        for i, link in enumerate(hand.link_names):
            T = np.linalg.solve(ref[hand.palm], ref[link])  # T_palm_link
            np.testing.assert_allclose(pose.R_palm_link[0, i], T[:3, :3], atol=1e-12)
            np.testing.assert_allclose(pose.r_palm_link[0, i], 1000.0 * T[:3, 3], atol=1e-9)
        for name, frame in hand.frames.items():  # merged links stay where the file puts them
            T = np.linalg.solve(ref[hand.palm], ref[name])
            T_palm_frame = pose.T_palm_link[0, hand.link_index(frame.link)] @ frame.T_link_frame
            np.testing.assert_allclose(T_palm_frame[:3, :3], T[:3, :3], atol=1e-12)
            np.testing.assert_allclose(T_palm_frame[:3, 3], 1000.0 * T[:3, 3], atol=1e-9)


@requires_hands
@pytest.mark.parametrize("path", SHARED)
def test_self_collision_at_zero_pose_runs(path):
    hand = hand_from_urdf(path)
    q0 = np.clip(0.0, hand.lower, hand.upper)
    clearance, names = capsule_clearances(hand, forward_kinematics(hand, q0))
    assert clearance.shape == (1, len(names)) and len(names) > 0
    assert np.all(np.isfinite(clearance))
    hits = sorted((float(c), pair) for c, pair in zip(clearance[0], names) if c < 0)
    print(f"\n{hand.name}: {len(names)} capsule pairs, min clearance {clearance.min():.2f} mm,", end=" ")
    print(f"{len(hits)} penetrating:")
    for c, pair in hits:
        print(f"  {pair[0]} / {pair[1]}: {c:.2f} mm")


# -- small inline URDFs ------------------------------------------------------------------------------
def _urdf(body: str, links=("palm", "a", "b", "c")) -> str:
    return "<robot name='t'>" + "".join(f"<link name='{n}'/>" for n in links) + body + "</robot>"


def _joint(name, parent, child, jtype="revolute", xyz="0 0 0", rpy="0 0 0", axis="0 0 1", extra=""):
    limit = "<limit lower='-1' upper='1'/>" if jtype == "revolute" else ""
    return (
        f"<joint name='{name}' type='{jtype}'><parent link='{parent}'/><child link='{child}'/>"
        f"<origin xyz='{xyz}' rpy='{rpy}'/><axis xyz='{axis}'/>{limit}{extra}</joint>"
    )


def test_fixed_joint_in_the_middle_is_merged():
    sphere = "<collision><origin xyz='0.005 0 0'/><geometry><sphere radius='0.004'/></geometry></collision>"
    text = (
        "<robot name='t'><link name='palm'/><link name='a'/>"
        f"<link name='b'>{sphere}</link><link name='c'/>"
        + _joint("j1", "palm", "a", xyz="0.01 0 0")
        + _joint("f", "a", "b", jtype="fixed", xyz="0 0.02 0", rpy=f"0 0 {math.pi / 2}")
        + _joint("j2", "b", "c", xyz="0.03 0 0", axis="1 0 0")
        + "</robot>"
    )
    hand = hand_from_urdf(text)
    assert hand.link_names == ("palm", "a", "c")
    j2 = hand.joints[1]
    assert j2.parent == "a"
    np.testing.assert_allclose(j2.origin_in_parent, [0.0, 50.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(j2.axis_in_parent, [0.0, 1.0, 0.0], atol=1e-12)
    (cap,) = hand.links[1].collision
    np.testing.assert_allclose([cap.a, cap.b], [[0.0, 25.0, 0.0]] * 2, atol=1e-12)
    assert cap.radius == pytest.approx(4.0)
    t1, t2 = 0.3, -0.7
    pose = forward_kinematics(hand, [t1, t2])
    np.testing.assert_allclose(pose.r_palm_link[0, 2], [10 - 50 * math.sin(t1), 50 * math.cos(t1), 0.0], atol=1e-12)
    Rz = Rotation.from_rotvec([0, 0, t1 + math.pi / 2]).as_matrix()
    np.testing.assert_allclose(pose.R_palm_link[0, 2], Rz @ Rotation.from_rotvec([t2, 0, 0]).as_matrix(), atol=1e-12)
    assert [f.name for f in hand.fingers] == ["a"] and hand.fingers[0].links == ("a", "c")
    assert hand.frames["b"].link == "a"  # the merged link stays as a named frame
    np.testing.assert_allclose(hand.frames["b"].origin, [0.0, 20.0, 0.0], atol=1e-12)
    with pytest.raises(InvalidHand, match=r"'b' not found: it is a frame fixed to link 'a'.*\[0, 20, 0\] mm"):
        hand.link_index("b")
    assert any("kept as named frames: b (on a)" in n for n in hand.notes)


def test_continuous_joint_default_axis_and_length_unit():
    joint = _joint("j", "palm", "a", jtype="continuous", xyz="1 2 3").replace("<axis xyz='0 0 1'/>", "")
    text = _urdf(joint, ("palm", "a"))
    hand = hand_from_urdf(text, name="h", length_unit=10.0)
    assert hand.name == "h"
    assert (hand.lower[0], hand.upper[0]) == (-math.pi, math.pi)
    np.testing.assert_allclose(hand.joints[0].axis_in_parent, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(hand.joints[0].origin_in_parent, [10.0, 20.0, 30.0])


def test_mimic_chain_is_resolved_to_the_independent_joint():
    text = _urdf(
        _joint("j1", "palm", "a")
        + _joint("j2", "a", "b", extra="<mimic joint='j1' multiplier='3' offset='0.2'/>")
        + _joint("j3", "b", "c", extra="<mimic joint='j2' multiplier='2' offset='0.1'/>")
    )
    hand = hand_from_urdf(text)
    got = {c.dof: (c.source, c.ratio, c.offset) for c in hand.couplings}
    assert got["j2"] == ("j1", 3.0, 0.2)
    assert got["j3"][0] == "j1"
    assert got["j3"][1:] == pytest.approx((6.0, 0.5))
    default = hand_from_urdf(
        _urdf(_joint("j1", "palm", "a") + _joint("j2", "a", "b", extra="<mimic joint='j1'/>"), ("palm", "a", "b"))
    )
    assert [(c.dof, c.source, c.ratio, c.offset) for c in default.couplings] == [("j2", "j1", 1.0, 0.0)]


def test_root_cuts_an_arm_at_the_wrist():
    arm = _urdf(
        _joint("slide", "base", "palm", jtype="prismatic") + _joint("j1", "palm", "a") + _joint("j2", "a", "b"),
        ("base", "palm", "a", "b"),
    )
    hand, warnings = load_urdf_hand(arm)  # a single chain: no branch, the root stays the palm
    assert hand.palm == "base" and hand.dof_names == ("j1", "j2")
    assert warnings == [
        "joint 'slide' is prismatic; prehension models revolute joints only: it is held at its reference "
        "position and 'palm' merged into its parent"
    ]
    hand = hand_from_urdf(arm, root="palm")
    assert hand.palm == "palm" and hand.dof_names == ("j1", "j2")
    assert not any(n.startswith("warning") for n in hand.notes)


def test_palm_is_where_the_fingers_branch():
    """A forearm and a wrist above the branching link are cut off, with a note."""
    text = _urdf(
        _joint("wrist", "forearm", "palm") + _joint("i1", "palm", "a") + _joint("t1", "palm", "b"),
        ("forearm", "palm", "a", "b"),
    )
    hand = hand_from_urdf(text)
    assert hand.palm == "palm" and hand.dof_names == ("i1", "t1")
    assert [f.links for f in hand.fingers] == [("a",), ("b",)]
    (note,) = [n for n in hand.notes if n.startswith("palm:")]
    assert "cut off above it: link(s) forearm and joint(s) wrist; read the file with root='forearm'" in note
    kept = hand_from_urdf(text, root="forearm")
    assert kept.palm == "forearm" and kept.dof_names == ("wrist", "i1", "t1")
    assert not any(n.startswith("palm:") for n in kept.notes)


def test_finger_names_use_a_common_stem():
    links = ("palm", "index_proximal", "index_distal", "thumb_proximal", "thumb_distal")
    text = _urdf(
        _joint("i1", "palm", "index_proximal")
        + _joint("i2", "index_proximal", "index_distal")
        + _joint("t1", "palm", "thumb_proximal")
        + _joint("t2", "thumb_proximal", "thumb_distal"),
        links,
    )
    hand = hand_from_urdf(text)
    assert [(f.name, f.links) for f in hand.fingers] == [
        ("index", ("index_proximal", "index_distal")),
        ("thumb", ("thumb_proximal", "thumb_distal")),
    ]


def test_branching_link_belongs_to_no_finger():
    text = _urdf(_joint("j1", "palm", "a") + _joint("j2", "a", "b") + _joint("j3", "a", "c") + _joint("j4", "palm", "d"),
                 ("palm", "a", "b", "c", "d"))  # fmt: skip
    hand = hand_from_urdf(text)
    assert hand.palm == "palm"
    assert [(f.name, f.links) for f in hand.fingers] == [("d", ("d",)), ("b", ("b",)), ("c", ("c",))]
    assert hand.finger_of_link("a") is None
    assert list(hand.chain_dofs("b")) == [hand.dof_index("j1"), hand.dof_index("j2")]


# -- errors ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, pattern",
    [
        ("<robot><link name='palm'", r"<URDF text>: not a valid XML document"),
        ("<model name='x'/>", r"root element is <model>, expected <robot>"),
        (_urdf(_joint("j", "palm", "a"), ("palm", "a", "b")), r"several root links.*palm, b.*root="),
        (_urdf(_joint("j", "palm", "ghost"), ("palm",)), r"joint 'j': its child link 'ghost' is not defined"),
        (_urdf(_joint("j", "a", "b") + _joint("k", "b", "a"), ("a", "b")), r"no root link.*cycle"),
        (_urdf(_joint("j", "palm", "a") + _joint("k", "b", "c") + _joint("m", "c", "b")), r"cycle"),
        (_urdf(_joint("j", "palm", "a") + _joint("k", "palm", "a"), ("palm", "a")), r"'a' is the child of several"),
        (
            _urdf(
                _joint("f", "palm", "a", jtype="fixed") + _joint("j", "a", "b", extra="<mimic joint='f'/>"),
                ("palm", "a", "b"),
            ),
            r"'j' follows joint 'f' \(a coupling\), which is fixed",
        ),
        (
            _urdf(_joint("j", "palm", "a", extra="<mimic joint='nope'/>"), ("palm", "a")),
            r"follows joint 'nope'.*not defined",
        ),
        (
            _urdf(
                _joint("j", "palm", "a", extra="<mimic joint='k'/>")
                + _joint("k", "a", "b", extra="<mimic joint='j'/>"),
                ("palm", "a", "b"),
            ),
            r"couplings form a cycle",
        ),
        (_urdf(_joint("j", "palm", "a").replace("<limit lower='-1' upper='1'/>", ""), ("palm", "a")), r"no <limit"),
    ],
)
def test_invalid_urdf(text, pattern):
    with pytest.raises(InvalidHand, match=pattern):
        hand_from_urdf(text)


def test_error_names_the_file(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text(_urdf(_joint("j", "palm", "a").replace("<limit lower='-1' upper='1'/>", ""), ("palm", "a")))
    with pytest.raises(InvalidHand, match=r"broken\.urdf: revolute joint 'j' has no <limit"):
        hand_from_urdf(path)
    with pytest.raises(InvalidHand, match=r"missing\.urdf: cannot read"):
        hand_from_urdf(tmp_path / "missing.urdf")
    with pytest.raises(InvalidHand, match=r"root link 'nope' not found"):
        hand_from_urdf(_urdf("", ("palm",)), root="nope")


# -- collision capsules ------------------------------------------------------------------------------
def _one_link(geometry: str, origin: str = "") -> str:
    collision = f"<collision>{origin}<geometry>{geometry}</geometry></collision>"
    return f"<robot name='s'><link name='palm'>{collision}</link></robot>"


def test_cylinder_capsule_encloses_the_cylinder():
    origin = f"<origin xyz='0 0 0.1' rpy='0 {math.pi / 2!r} 0'/>"
    long_ = hand_from_urdf(_one_link("<cylinder radius='0.01' length='0.05'/>", origin))
    (cap,) = long_.links[0].collision
    assert 10.0 <= cap.radius <= 11.0
    half = abs(cap.a[0] - cap.b[0]) / 2
    assert half**2 + 0.0 <= 25.0**2  # along x after pitch 90
    assert (25.0 - half) ** 2 + 10.0**2 <= cap.radius**2 + 1e-6  # the rims are inside
    np.testing.assert_allclose([cap.a[1:], cap.b[1:]], [[0.0, 100.0]] * 2, atol=1e-9)
    assert long_.links[0].fit.miss_mm == 0.0
    assert long_.links[0].fit.stick_out_mm == pytest.approx(cap.radius - (25.0 - half), abs=0.05)
    (disc,) = hand_from_urdf(_one_link("<cylinder radius='0.03' length='0.01'/>")).links[0].collision
    assert math.hypot(30.0, 5.0) <= disc.radius <= math.hypot(30.0, 5.0) + 0.1  # a sphere through both rims
    np.testing.assert_allclose([disc.a, disc.b], np.zeros((2, 3)), atol=1e-12)


def test_box_capsules_enclose_the_box():
    hand = hand_from_urdf(_one_link("<box size='0.02 0.05 0.012'/>"))
    caps = hand.links[0].collision
    assert len(caps) == 2  # ceil(20 / 12)
    corners = np.array([[x, y, z] for x in (-10, 10) for y in (-25, 25) for z in (-6, 6)], dtype=float)
    grid = np.stack(np.meshgrid(*(np.linspace(-h, h, 9) for h in (10, 25, 6))), axis=-1).reshape(-1, 3)
    assert capsule_gaps(np.concatenate([corners, grid]), caps).max() <= 1e-9  # the whole box is inside
    for c in caps:
        assert abs(c.a[0] - c.b[0]) < 1e-12 and abs(c.a[2] - c.b[2]) < 1e-12  # along the long side (y)
        assert c.radius >= math.hypot(5.0, 6.0) - 1e-9  # holds its slab's corners
    assert sorted(c.a[0] for c in caps) == pytest.approx([-5.0, 5.0])  # one per half of the mid side (x)
    fit = hand.links[0].fit
    assert fit.miss_mm == 0.0 and 0.0 < fit.stick_out_mm <= max(c.radius for c in caps) + 0.05


def _cylinder_points(length=0.04, radius=0.005):
    """A grid of points on a cylinder surface along the direction (1, 1, 0)/sqrt 2, centre (0.01, 0, 0)."""
    t, phi = np.meshgrid(np.linspace(-length / 2, length / 2, 21), np.linspace(0, 2 * np.pi, 24, endpoint=False))
    t, phi = t.ravel(), phi.ravel()
    u = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    v, w = np.array([1.0, -1.0, 0.0]) / np.sqrt(2), np.array([0.0, 0.0, 1.0])
    pts = t[:, None] * u + radius * (np.cos(phi)[:, None] * v + np.sin(phi)[:, None] * w)
    return pts + [0.01, 0.0, 0.0], u


def _write_obj(path, pts):
    """Every point a corner of a triangle (consecutive triples, the last wrapping round):
    vertices no face uses are not part of the mesh."""
    n = len(pts)
    faces = "".join(f"f {i + 1} {(i + 1) % n + 1} {(i + 2) % n + 1}\n" for i in range(0, n, 3))
    path.write_text("# test\no x\n" + "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()) + faces)


def _write_stl(path, pts, binary):
    tris = pts[: len(pts) // 3 * 3].reshape(-1, 3, 3)
    if binary:
        body = b"".join(struct.pack("<12fH", 0, 0, 0, *t.ravel(), 0) for t in tris)
        path.write_bytes(b"\0" * 80 + struct.pack("<I", len(tris)) + body)
    else:
        facets = "".join(
            "facet normal 0 0 0\nouter loop\n"
            + "".join(f"vertex {x!r} {y!r} {z!r}\n" for x, y, z in t.tolist())
            + "endloop\nendfacet\n"
            for t in tris
        )
        path.write_text(f"solid x\n{facets}endsolid x\n")


@pytest.mark.parametrize("kind", ["obj", "stl-binary", "stl-ascii"])
def test_mesh_capsule_from_file(tmp_path, kind):
    pts, u = _cylinder_points()
    mesh = tmp_path / "pkg" / "meshes" / ("m.obj" if kind == "obj" else "m.stl")
    mesh.parent.mkdir(parents=True)
    if kind == "obj":
        _write_obj(mesh, pts)
    else:
        _write_stl(mesh, pts, binary=kind == "stl-binary")
        pts = pts[: len(pts) // 3 * 3]
    stored = pts.astype(np.float32).astype(float) if kind == "stl-binary" else pts  # binary STL stores float32
    np.testing.assert_array_equal(read_mesh_vertices(mesh), np.unique(stored, axis=0))  # distinct, sorted
    urdf = tmp_path / "pkg" / "urdf" / "h.urdf"
    urdf.parent.mkdir()
    urdf.write_text(_one_link(f"<mesh filename='package://pkg/meshes/{mesh.name}' scale='2 2 2'/>"))
    hand, warnings = load_urdf_hand(urdf)
    assert warnings == []
    (cap,) = hand.links[0].collision
    axis = (cap.b - cap.a) / np.linalg.norm(cap.b - cap.a)
    assert abs(axis @ u) == pytest.approx(1.0, abs=1e-2)
    assert 10.0 <= cap.radius <= 10.2  # 5 mm * scale 2; a slightly larger radius shortens the segment
    np.testing.assert_allclose((cap.a + cap.b) / 2, [20.0, 0.0, 0.0], atol=1.0)
    assert 76.0 <= np.linalg.norm(cap.b - cap.a) <= 80.0 + 1e-6  # the rims at +-40 mm are inside
    assert capsule_gaps(2 * pts * 1000, [cap]).max() <= 1e-6


def test_mesh_capsule_of_collinear_points_is_refused():
    with pytest.raises(ValueError, match="collinear"):
        mesh_capsule([[0, 0, 0], [1, 0, 0], [2, 0, 0]])


def test_missing_or_unsupported_mesh_is_skipped_with_a_warning(tmp_path):
    (tmp_path / "m.3ds").write_bytes(b"MM\0\0")
    text = (
        "<robot name='s'><link name='palm'>"
        "<collision><geometry><mesh filename='package://nowhere/x.stl'/></geometry></collision>"
        "<collision><geometry><mesh filename='m.3ds'/></geometry></collision>"
        "<collision><geometry><sphere radius='0.01'/></geometry></collision>"
        "</link></robot>"
    )
    path = tmp_path / "h.urdf"
    path.write_text(text)
    hand, warnings = load_urdf_hand(path)
    assert len(hand.links[0].collision) == 1 and hand.links[0].collision[0].radius == pytest.approx(10.0)
    assert len(warnings) == 2
    assert "collision 0" in warnings[0] and "'package://nowhere/x.stl' not found" in warnings[0]
    assert "collision 1" in warnings[1] and f"{tmp_path / 'm.3ds'}: unsupported mesh format .3ds" in warnings[1]
    assert "mesh files are read from .obj, .stl, .ply, .off, .glb, .gltf" in warnings[1]
    assert len(hand_from_urdf(path).links[0].collision) == 1
