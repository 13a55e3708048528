"""Hands written as URDF and MJCF and read back: the same kinematics (and MuJoCo loads it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import random_angles
from prehension.geometry.bezier import BezierPatch
from prehension.geometry.regions import BezierRegion, PointRegion, SphereCap
from prehension.hands.export import hand_to_mjcf, hand_to_urdf, region_frame_name
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.model import HandRegion
from prehension.hands.urdf import hand_from_urdf

COUPLED = Path(__file__).resolve().parent / "data" / "coupled_hand.xml"


def _same_kinematics(original, copy, rng, n=50, atol=1e-9):
    """Every link and named frame of ``original`` sits where ``copy`` puts it [mm]."""
    assert set(original.dof_names) == set(copy.dof_names)
    for d in original.dof_names:
        i, k = original.dof_index(d), copy.dof_index(d)
        assert (copy.lower[k], copy.upper[k]) == pytest.approx((original.lower[i], original.upper[i]), abs=1e-15)
    q = random_angles(original, rng, n)
    qq = np.stack([q[:, original.dof_index(d)] for d in copy.dof_names], axis=1)
    a, b = forward_kinematics(original, q), forward_kinematics(copy, qq)
    for link in original.link_names:
        T = b.T_palm_link[:, copy.link_index(link)] if link in copy.link_names else _frame(copy, b, link)
        np.testing.assert_allclose(T, a.T_palm_link[:, original.link_index(link)], atol=atol)


def _frame(hand, pose, name):
    frame = hand.frames[name]
    return pose.T_palm_link[:, hand.link_index(frame.link)] @ frame.T_link_frame


def test_sa_hand_to_urdf_and_back(sa_hand, tmp_path, rng):
    path = tmp_path / "sa.urdf"
    path.write_text(hand_to_urdf(sa_hand))
    again = hand_from_urdf(path)
    assert again.palm == "palm" and [f.name for f in again.fingers] == [f.name for f in sa_hand.fingers]
    assert again.opposing_finger == "thumb"
    assert {(c.dof, c.source, c.ratio, c.offset) for c in again.couplings} == {
        (c.dof, c.source, c.ratio, c.offset) for c in sa_hand.couplings
    }
    _same_kinematics(sa_hand, again, rng)
    for name, reg in sa_hand.regions.items():  # each cap's centre is a named frame of the copy
        frame = again.frames[region_frame_name(sa_hand, name)]
        assert frame.link == reg.link
        np.testing.assert_allclose(frame.origin, reg.region.center, atol=1e-12)
        np.testing.assert_allclose(frame.T_link_frame[:3, 2], reg.region.axis, atol=1e-12)


def test_sa_hand_to_mjcf_loads_in_mujoco_and_back(sa_hand, tmp_path, rng):
    mujoco = pytest.importorskip("mujoco")
    from prehension.hands.mjcf import hand_from_mjcf

    path = tmp_path / "sa.xml"
    path.write_text(hand_to_mjcf(sa_hand))
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.njnt == sa_hand.n_dof and model.neq == len(sa_hand.couplings)
    again = hand_from_mjcf(path)
    assert again.palm == "palm" and [f.name for f in again.fingers] == [f.name for f in sa_hand.fingers]
    _same_kinematics(sa_hand, again, rng)
    data = mujoco.MjData(model)  # MuJoCo's own kinematics of the file agree too
    q = random_angles(sa_hand, rng, 1)[0]
    for j in range(model.njnt):
        data.qpos[model.jnt_qposadr[j]] = q[sa_hand.dof_index(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j))]
    mujoco.mj_kinematics(model, data)
    pose = forward_kinematics(sa_hand, q)
    for i, link in enumerate(sa_hand.link_names):
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link)
        np.testing.assert_allclose(1000.0 * data.xpos[b], pose.r_palm_link[0, i], atol=1e-9)
        np.testing.assert_allclose(data.xmat[b].reshape(3, 3), pose.R_palm_link[0, i], atol=1e-12)


def test_joint_centres_off_the_child_frame_export(tmp_path, rng):
    """A joint whose centre is not its child's origin (MJCF joint pos) survives both formats."""
    pytest.importorskip("mujoco")
    from prehension.hands.mjcf import hand_from_mjcf

    hand = hand_from_mjcf(COUPLED)
    assert np.any(hand.joint_of_link("thumb_base").origin_in_child != 0)  # the hinges' pos="0 0 0.002"
    (tmp_path / "h.urdf").write_text(hand_to_urdf(hand))
    (tmp_path / "h.xml").write_text(hand_to_mjcf(hand))
    _same_kinematics(hand, hand_from_urdf(tmp_path / "h.urdf"), rng)
    again = hand_from_mjcf(tmp_path / "h.xml")
    _same_kinematics(hand, again, rng)
    assert set(hand.collision_exclusions) <= set(again.collision_exclusions)


def test_only_regions_with_a_frame_of_their_own_are_marked(sa_hand, tmp_path):
    """A point and a Bézier region have no frame (Region.frame is None): nothing is
    written for them; a sphere cap is marked by its frame, in URDF and in MJCF."""
    cap = SphereCap((5.0, 1.0, 2.0), 7.0, (0.2, 0.9, 0.1), 0.7)
    flat = BezierPatch.bilinear((0.0, 0.0, 0.0), (0.0, 10.0, 0.0), (10.0, 0.0, 1.0), (10.0, 10.0, 0.0))
    hand = sa_hand.with_regions({
        "pt": HandRegion("palm", PointRegion((1.0, 2.0, 3.0), (0.0, 0.3, 1.0))),
        "bz": HandRegion("palm", BezierRegion(flat)),
        "cap2": HandRegion("palm", cap),
    })  # fmt: skip
    assert hand.regions["pt"].region.frame is None and hand.regions["bz"].region.frame is None
    np.testing.assert_allclose(cap.frame[:, 2], cap.axis, atol=1e-15)
    urdf, mjcf = hand_to_urdf(hand), hand_to_mjcf(hand)
    for name in ("pt", "bz"):
        assert f'"{name}"' not in urdf and f'"{name}"' not in mjcf
    assert 'link name="cap2"' in urdf and 'site name="cap2"' in mjcf
    path = tmp_path / "h.urdf"
    path.write_text(urdf)
    frame = hand_from_urdf(path).frames["cap2"]
    assert frame.link == "palm"
    np.testing.assert_allclose(frame.origin, cap.center, atol=1e-12)
    np.testing.assert_allclose(frame.T_link_frame[:3, 2], cap.axis, atol=1e-12)
