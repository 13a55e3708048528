"""Reading hands from MJCF through MuJoCo: the shared URDF hands compiled by MuJoCo, a
hand-written MJCF with equality couplings, and the errors."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import HANDS_DIR, random_angles
from prehension.errors import InvalidHand, PrehensionError
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.urdf import hand_from_urdf

mujoco = pytest.importorskip("mujoco")

from prehension.hands.mjcf import hand_from_mjcf, urdf_to_mjcf  # noqa: E402

DATA = Path(__file__).resolve().parent / "data"
COUPLED = DATA / "coupled_hand.xml"
requires_hands = pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")
SHARED = [
    pytest.param(HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf", id="svh"),
    pytest.param(HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf", id="allegro"),
]


def _mujoco_poses(path, qpos_by_name: dict[str, float]) -> dict[str, np.ndarray]:
    """T_world_body (mm) of every body by MuJoCo's own forward kinematics."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        d.qpos[m.jnt_qposadr[j]] = qpos_by_name.get(name, m.qpos0[m.jnt_qposadr[j]])
    mujoco.mj_kinematics(m, d)
    out = {}
    for b in range(m.nbody):
        T = np.eye(4)
        T[:3, :3] = d.xmat[b].reshape(3, 3)
        T[:3, 3] = 1000.0 * d.xpos[b]
        out[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)] = T
    return out


# -- the shared hands, compiled by MuJoCo ------------------------------------------------------------
@requires_hands
@pytest.mark.parametrize("urdf", SHARED)
def test_shared_hand_as_mjcf_is_the_urdf_hand(urdf, tmp_path, rng):
    xml = urdf_to_mjcf(urdf, tmp_path / "hand.xml")
    hand, ref = hand_from_mjcf(xml), hand_from_urdf(urdf)
    assert hand.palm == ref.palm and hand.link_names == ref.link_names and hand.dof_names == ref.dof_names
    np.testing.assert_allclose(hand.lower, ref.lower, atol=1e-12)
    np.testing.assert_allclose(hand.upper, ref.upper, atol=1e-12)
    assert [(c.dof, c.source) for c in hand.couplings] == [(c.dof, c.source) for c in ref.couplings]
    np.testing.assert_allclose([c.ratio for c in hand.couplings], [c.ratio for c in ref.couplings], atol=1e-12)
    assert [(f.name, f.links) for f in hand.fingers] == [(f.name, f.links) for f in ref.fingers]
    assert hand.opposing_finger == ref.opposing_finger == "thumb"
    assert set(hand.frames) == set(ref.frames) and set(hand.regions) == set(ref.regions)
    q = random_angles(ref, rng, 20)
    mine, theirs = forward_kinematics(hand, q), forward_kinematics(ref, q)
    # mj_saveLastXML writes 6 significant digits: poses agree to a micrometre
    np.testing.assert_allclose(mine.r_palm_link, theirs.r_palm_link, atol=2e-3)
    np.testing.assert_allclose(mine.R_palm_link, theirs.R_palm_link, atol=2e-5)
    for name, region in ref.regions.items():  # the same fingertip from the same geometry
        cap, cap_ref = hand.regions[name].region, region.region
        assert hand.regions[name].link == region.link
        np.testing.assert_allclose(cap.center, cap_ref.center, atol=0.05)
        # the pad takes in its tip capsule's end ball (docs/hands.md, fingertip step 5), and
        # the capsule fits of the two files' meshes (6 digits) differ by up to 0.2 mm in reach
        assert cap.radius == pytest.approx(cap_ref.radius, abs=0.25)


@requires_hands
@pytest.mark.parametrize("urdf", SHARED)
def test_shared_hand_fk_matches_mujoco(urdf, tmp_path, rng):
    xml = urdf_to_mjcf(urdf, tmp_path / "hand.xml")
    hand = hand_from_mjcf(xml)
    for q in random_angles(hand, rng, 5):
        poses = _mujoco_poses(xml, dict(zip(hand.dof_names, q)))
        pose = forward_kinematics(hand, q)
        T_world_palm = poses[hand.palm]
        for i, link in enumerate(hand.link_names):
            T = np.linalg.solve(T_world_palm, poses[link])
            np.testing.assert_allclose(pose.T_palm_link[0, i], T, atol=1e-9)


# -- a hand-written MJCF ----------------------------------------------------------------------------
def test_coupled_hand_structure():
    hand = hand_from_mjcf(COUPLED)
    assert hand.name == "coupled-hand" and hand.palm == "palm"
    assert [f.name for f in hand.fingers] == ["index", "middle", "thumb"] and hand.opposing_finger == "thumb"
    assert hand.finger("index").links == ("index_proximal:index_abd", "index_proximal", "index_middle", "index_distal")
    cpl = {c.dof: (c.source, c.ratio, c.offset) for c in hand.couplings}
    assert cpl["index_dip"] == ("index_pip", 0.8, 0.0)
    assert cpl["middle_dip"][:2] == ("middle_pip", 0.75) and cpl["middle_dip"][2] == pytest.approx(math.radians(5))
    i = hand.dof_index("thumb_rot")
    assert (hand.lower[i], hand.upper[i]) == pytest.approx((math.radians(-10), math.radians(100)))
    assert "wrist_flex" not in hand.dof_names
    (note,) = [n for n in hand.notes if n.startswith("palm:")]
    assert "cut off above it: link(s) forearm and joint(s) wrist_flex; read the file with root='forearm'" in note
    assert hand.frames["index_tip_site"].link == "index_distal"
    np.testing.assert_allclose(hand.frames["index_tip_site"].origin, [0, 0, 20.5], atol=1e-9)
    assert set(hand.regions) == {"index_tip", "middle_tip", "thumb_tip"}
    middle = hand.regions["middle_tip"].region  # a sphere geom: the fit is the sphere
    np.testing.assert_allclose(middle.center, [0, 0, 11.0], atol=1e-6)
    assert middle.radius == pytest.approx(9.5, abs=1e-6)
    assert hand.tip_fits["middle_tip"].rms_mm < 1e-6
    np.testing.assert_allclose(middle.axis, [math.cos(math.radians(20)), 0, math.sin(math.radians(20))], atol=1e-9)
    assert hand.collision_exclusions[0] == ("palm", "thumb_distal")  # the file's <contact><exclude>
    assert ("palm", "thumb_base") in hand.collision_exclusions  # capsules overlapping at rest (noted)
    assert any("not checked between" in n and "palm/thumb_base" in n for n in hand.notes)
    kept = hand_from_mjcf(COUPLED, root="forearm")
    assert kept.palm == "forearm" and kept.dof_names[0] == "wrist_flex"


def test_coupled_hand_fk_matches_mujoco(rng):
    """Two hinges in one body, a non-zero ref, welded bodies and sites, against MuJoCo."""
    hand = hand_from_mjcf(COUPLED)
    for q in random_angles(hand, rng, 10):
        poses = _mujoco_poses(COUPLED, {**dict(zip(hand.dof_names, q)), "wrist_flex": 0.3})
        pose = forward_kinematics(hand, q)
        for i, link in enumerate(hand.link_names):
            if ":" in link:  # intermediate links of multi-joint bodies are ours only
                continue
            T = np.linalg.solve(poses["palm"], poses[link])
            np.testing.assert_allclose(pose.T_palm_link[0, i], T, atol=1e-9)


def _write(tmp_path, body: str, equality: str = "", name: str = "h.xml") -> Path:
    text = f"<mujoco model='t'><compiler angle='radian' autolimits='true'/><worldbody>{body}</worldbody>"
    text += f"<equality>{equality}</equality></mujoco>" if equality else "</mujoco>"
    path = tmp_path / name
    path.write_text(text)
    return path


_TWO = (
    "<body name='p'><geom type='sphere' size='0.01'/>"
    "<body name='a' pos='0 0 0.02'><joint name='ja' axis='0 1 0' range='0 1'/><geom type='capsule' size='0.005 0.01'/></body>"
    "<body name='b' pos='0 0.02 0.02'><joint name='jb' axis='0 1 0' range='0 1'/><geom type='sphere' size='0.005'/>"
    "<body name='c' pos='0 0 0.02'><joint name='jc' axis='0 1 0' range='0 1'/><geom type='sphere' size='0.005'/>"
    "</body></body></body>"
)


def test_polynomial_coupling_is_refused(tmp_path):
    path = _write(tmp_path, _TWO, "<joint joint1='jc' joint2='jb' polycoef='0 1 0.5 0 0'/>")
    with pytest.raises(InvalidHand, match=r"h\.xml: .*'jc' follows joint 'jb' by the polynomial.*linearly only"):
        hand_from_mjcf(path)


def test_coupling_without_a_second_joint_holds_the_angle(tmp_path):
    path = _write(tmp_path, _TWO, "<joint joint1='jc' polycoef='0.25 0 0 0 0'/>")
    hand = hand_from_mjcf(path)
    i = hand.dof_index("jc")
    assert hand.lower[i] == hand.upper[i] == 0.25
    assert any("'jc' is held at 14.3239 deg" in n for n in hand.notes)


def test_unsupported_joints_and_ignored_elements_are_noted(tmp_path):
    body = _TWO.replace("<joint name='jc' axis='0 1 0' range='0 1'/>", "<joint name='jc' type='slide' range='0 0.01'/>")
    body = body.replace("<body name='p'>", "<body name='p'><geom type='plane' size='1 1 1'/>")
    path = _write(tmp_path, body, "<connect body1='a' body2='b' anchor='0 0 0'/>")
    hand = hand_from_mjcf(path)
    assert hand.dof_names == ("ja", "jb")
    notes = "\n".join(hand.notes)
    assert "joint 'jc' is slide; prehension models revolute joints only: it is held" in notes
    assert "equality 0 (connect) is ignored" in notes
    assert "a plane is not a hand shape; skipped" in notes


def test_top_bodies_without_hinges_and_free_joints_are_dropped(tmp_path):
    body = _TWO.replace("<body name='p'>", "<body name='p'><freejoint name='float'/>")
    path = _write(tmp_path, body + "<body name='table' pos='0 0 -1'><geom type='box' size='1 1 0.01'/></body>")
    hand = hand_from_mjcf(path)
    assert hand.palm == "p" and hand.dof_names == ("ja", "jb", "jc")
    notes = "\n".join(hand.notes)
    assert "the free joint 'float' of the top body 'p' is dropped" in notes
    assert "top body 'table' holds no hinge joint: not part of the hand" in notes
    two = _write(tmp_path, _TWO + _TWO.replace("name='", "name='x"), name="two.xml")
    with pytest.raises(InvalidHand, match=r"two\.xml: several top bodies hold hinge joints: p, xp; choose the hand with root="):
        hand_from_mjcf(two)
    assert hand_from_mjcf(two, root="xp").dof_names == ("xja", "xjb", "xjc")


def test_errors_name_the_file(tmp_path):
    with pytest.raises(InvalidHand, match=r"missing\.xml: MuJoCo cannot read the file"):
        hand_from_mjcf(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body name='x'><joint type='hinge' range='2 1'/></body></worldbody></mujoco>")
    with pytest.raises(InvalidHand, match=r"bad\.xml: MuJoCo cannot compile the file"):
        hand_from_mjcf(bad)


def test_missing_mujoco_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(PrehensionError, match=r'needs the mujoco package; install it with: pip install "prehension\[mjcf\]"'):
        hand_from_mjcf(COUPLED)
