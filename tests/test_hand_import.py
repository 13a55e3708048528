"""What the import of a hand file finds by itself: palm, finger names, fingertip caps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from prehension.errors import InvalidHand
from prehension.hands.description import RawShape
from prehension.hands.export import hand_to_urdf
from prehension.hands.fingertips import PadFrame, TipOverride, apply_override, fit_fingertip
from prehension.hands.shapes import surface_points
from prehension.hands.urdf import hand_from_urdf


def _frame(length=30.0, pad=(0.0, 0.0, 1.0)):
    return PadFrame("d", np.zeros(3), np.array([1.0, 0, 0]), np.array([0, -1.0, 0]), np.array(pad), length, "test")


def _capsule_points(radius, a, b, n=600):
    length = float(np.linalg.norm(np.subtract(b, a)))
    z = (np.subtract(b, a)) / length
    x = np.cross(z, [0, 0, 1.0]) if abs(z[2]) < 0.9 else np.cross(z, [1.0, 0, 0])
    x /= np.linalg.norm(x)
    R = np.column_stack([x, np.cross(z, x), z])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, (np.add(a, b)) / 2
    return surface_points(RawShape("capsule", "collision", T, (radius, length)), n)


@pytest.mark.parametrize("seed", range(4))
def test_fit_recovers_a_spherical_tip(seed):
    """A sphere fingertip (any radius, any centre along the finger): the fit is the sphere."""
    rng = np.random.default_rng(seed)
    r, x = rng.uniform(5, 15), rng.uniform(10, 30)
    T = np.eye(4)
    T[:3, 3] = (x, 0, 0)
    pts = surface_points(RawShape("sphere", "collision", T, (r,)), 800)
    cap, fit = fit_fingertip("f", _frame(length=x + r), pts, "collision shapes")
    assert cap.radius == pytest.approx(r, abs=1e-6)
    np.testing.assert_allclose(cap.center, [x, 0, 0], atol=1e-6)
    assert fit.rms_mm < 1e-6 and fit.n_points > 20
    tilt = math.radians(20)
    np.testing.assert_allclose(cap.axis, [math.sin(tilt), 0, math.cos(tilt)], atol=1e-12)  # the pad, towards the tip
    assert math.degrees(cap.half_angle) == pytest.approx(60.0)


def test_fit_of_a_capsule_tip_hugs_its_end():
    pts = _capsule_points(8.0, (0, 0, 0), (20, 0, 0))
    cap, fit = fit_fingertip("f", _frame(length=28.0), pts, "collision shapes")
    assert 8.0 <= cap.radius <= 11.0  # the rounded end and the pad beside it
    assert abs(cap.center[1]) < 0.5 and cap.center[0] > 10.0
    u = pts - cap.center
    d = np.linalg.norm(u, axis=1)
    in_cap = (u @ cap.axis) / d >= math.cos(cap.half_angle)  # the report covers every point the cap stands for
    assert fit.n_points == in_cap.sum() > 50
    assert fit.max_mm == pytest.approx(np.abs(d[in_cap] - cap.radius).max())
    assert fit.rms_mm < 0.5 and fit.max_mm < 2.5  # a capsule is not a sphere: the report says by how much


def test_pad_side_follows_the_flexion():
    pts = _capsule_points(8.0, (0, 0, 0), (20, 0, 0))
    up, _ = fit_fingertip("f", _frame(28.0, pad=(0, 0, 1.0)), pts, "x")
    down, _ = fit_fingertip("f", _frame(28.0, pad=(0, 0, -1.0)), pts, "x")
    assert up.axis[2] > 0.9 and down.axis[2] < -0.9


def test_overrides():
    pts = _capsule_points(8.0, (0, 0, 0), (20, 0, 0))
    cap, fit = fit_fingertip("f", _frame(28.0), pts, "collision shapes")
    new, report = apply_override(cap, fit, "f", "d", TipOverride(radius=12.0, half_angle_deg=30))
    assert new.radius == 12.0 and new.half_angle == pytest.approx(math.radians(30))
    np.testing.assert_array_equal(new.center, cap.center)
    assert report.overridden == ("radius", "half_angle_deg") and report.rms_mm == fit.rms_mm
    with pytest.raises(InvalidHand, match=r"finger 'f': no fingertip could be fitted.*missing: center, axis"):
        apply_override(None, None, "f", "d", TipOverride(radius=3, half_angle_deg=40))
    full = TipOverride(center=(1, 2, 3), radius=4, axis=(0, 0, 1), half_angle_deg=50)
    new, report = apply_override(None, None, "f", "d", full)
    assert report.geometry == "override" and new.radius == 4


def _renamed_sa_urdf(sa_hand) -> str:
    """The SA hand exported with finger names that say nothing (fa .. fd)."""
    text = hand_to_urdf(sa_hand)
    for old, new in (("ring", "fa"), ("middle", "fb"), ("index", "fc"), ("thumb", "fd")):
        text = text.replace(f'"{old}_', f'"{new}_')
    return text


def test_fingers_named_from_the_geometry(sa_hand):
    hand = hand_from_urdf(_renamed_sa_urdf(sa_hand))
    got = {f.name: f.links[-1] for f in hand.fingers}
    assert got == {"ring": "fa_distal", "middle": "fb_distal", "index": "fc_distal", "thumb": "fd_distal"}
    assert hand.opposing_finger == "thumb"
    assert any(n.startswith("fingers named from the geometry") for n in hand.notes)
    assert set(hand.regions) == {"ring_tip", "middle_tip", "index_tip", "thumb_tip"}


def test_no_thumb_without_opposition(sa_hand):
    """Three parallel fingers: nothing opposes, the names come from the links."""
    import xml.etree.ElementTree as ET

    robot = ET.fromstring(_renamed_sa_urdf(sa_hand).split("\n", 1)[1])
    for elem in list(robot):
        refs = [elem.get("name", "")] + [e.get("link", "") for e in elem if e.tag in ("parent", "child")]
        if any("fd_" in r or r.startswith("thumb") for r in refs):
            robot.remove(elem)
    hand = hand_from_urdf(ET.tostring(robot, encoding="unicode"))
    assert hand.opposing_finger is None
    assert [f.name for f in hand.fingers] == ["fa", "fb", "fc"]
    assert any(n.startswith("no finger opposes the others clearly") for n in hand.notes)


def _three_fingers(tip_geometry: str = "") -> str:
    """palm -> a1 -> a2 (tip geometry), palm -> b1, palm -> c1; b1 mimics c1."""
    def joint(name, parent, child, xyz, extra=""):
        return (f"<joint name='{name}' type='revolute'><parent link='{parent}'/><child link='{child}'/>"
                f"<origin xyz='{xyz}'/><axis xyz='0 1 0'/><limit lower='0' upper='1.5'/>{extra}</joint>")  # fmt: skip

    links = "".join(f"<link name='{n}'/>" for n in ("palm", "a1", "b1", "c1"))
    links += f"<link name='a2'>{tip_geometry}</link>"
    joints = joint("ja1", "palm", "a1", "0 0.02 0.1") + joint("ja2", "a1", "a2", "0 0 0.04")
    joints += joint("jb", "palm", "b1", "0 0 0.1", "<mimic joint='jc' multiplier='0.5'/>") + joint("jc", "palm", "c1", "0 -0.02 0.1")
    return f"<robot name='three'>{links}{joints}</robot>"


def test_a_finger_without_geometry_has_no_fingertip_and_a_note():
    hand = hand_from_urdf(_three_fingers())
    assert not hand.regions
    assert any("finger 'a1': no fingertip found (no geometry on link 'a2')" in n for n in hand.notes)
    sphere = "<collision><origin xyz='0 0 0.01'/><geometry><sphere radius='0.008'/></geometry></collision>"
    hand = hand_from_urdf(_three_fingers(sphere))
    assert hand.regions["a1_tip"].link == "a2" and hand.regions["a1_tip"].region.radius == pytest.approx(8.0)
    override = {"b1": TipOverride(center=(0, 0, 5), radius=4, axis=(1, 0, 0), half_angle_deg=45)}
    hand = hand_from_urdf(_three_fingers(), fingertips=override)
    assert set(hand.regions) == {"b1_tip"} and hand.tip_fits["b1_tip"].geometry == "override"


def test_coupled_dofs_take_part_together():
    from prehension.geometry.regions import PointRegion
    from prehension.hands.model import HandRegion
    from prehension.objects.model import GraspObject
    from prehension.tasks.model import Contact, Task

    hand = hand_from_urdf(_three_fingers())
    assert [f.name for f in hand.fingers] == ["a1", "b1", "c1"]
    mask = hand.active_dofs(["b1"])  # b1's joint follows c1's: both move
    assert [d for d, m in zip(hand.dof_names, mask) if m] == ["jb", "jc"]
    hand = hand.with_regions({"b": HandRegion("b1", PointRegion((0, 0, 5), (1, 0, 0)))})
    task = Task("t", hand, GraspObject("o", {"p": PointRegion((0, 0, 0), (1, 0, 0))}), (Contact("b", "p"),), ("b1",))
    np.testing.assert_array_equal(task.active_mask, mask)
    assert task.counts()["independent_angles"] == 1


def test_sphere_cap_in_degrees_as_in_files():
    from prehension.geometry.regions import SphereCap

    cap = SphereCap.from_degrees((1, 2, 3), 13.0, (0, 0, 1), 60)
    assert cap.half_angle == pytest.approx(math.pi / 3) and cap.radius == 13.0
