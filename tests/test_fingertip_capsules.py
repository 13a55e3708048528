"""A fitted fingertip pad agrees with its link's collision capsules (docs/hands.md, step 5):
a contact anywhere on the cap, against a flat surface, sinks no capsule of the link into
it beyond what the pad rule excuses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from prehension.hands.fingertips import OUTERMOST_MM, PadFrame, fit_fingertip, fit_to_capsules
from prehension.hands.model import Capsule
from prehension.hands.urdf import hand_from_urdf
from prehension.tasks.object_collision import _kept_pieces

from conftest import HANDS_DIR

ALLEGRO = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
SVH = HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf"
requires_hands = pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")


def _frame(length=30.0):
    """Finger along +x from the origin, flexing towards +z."""
    return PadFrame("d", np.zeros(3), np.array([1.0, 0, 0]), np.array([0, -1.0, 0]), np.array([0, 0, 1.0]), length, "test")


def _cap_directions(cap, rng, n=400) -> np.ndarray:
    """(n, 3) random unit directions inside the cap's cone, its rim included."""
    m = np.asarray(cap.axis)
    e1 = np.cross(m, [1.0, 0, 0] if abs(m[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(m, e1)
    t = np.concatenate([rng.uniform(0, cap.half_angle, n - 100), np.full(100, cap.half_angle)])
    phi = rng.uniform(0, 2 * math.pi, n)
    return np.cos(t)[:, None] * m + np.sin(t)[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)


def _plane_depth(capsules, centre, rho, u) -> float:
    """Deepest capsule of the link into the half-space beyond the pad's point ``centre + rho u``
    (normal ``u``), with what lies inside the pad excused (the residual function's rule) [mm]."""
    p = centre + rho * u
    depth = 0.0
    for cap in capsules:
        for a, b in _kept_pieces(np.asarray(cap.a, float), np.asarray(cap.b, float), cap.radius, [(centre, rho)]):
            depth = max(depth, max(a @ u, b @ u) - p @ u + cap.radius)
    return depth


def _random_tip(rng):
    """A sphere tip of radius ``rho`` at ``(x, 0, 0)``, a capsule around it a little thicker
    ending a little behind its centre, and a wide capsule across the phalanx behind it."""
    rho, x = rng.uniform(6, 14), rng.uniform(20, 40)
    back, extra = rng.uniform(0, 0.05) * rho, rng.uniform(0, 0.05) * rho
    tip = Capsule((x - rho, 0, 0), (x - back, 0, 0), rho + extra)
    half_width = rng.uniform(0.5, 1.2) * rho
    body = Capsule((x - rng.uniform(1.2, 2.0) * rho, -half_width, 0), (x - rng.uniform(1.2, 2.0) * rho, half_width, 0),
                   rng.uniform(0.8, 1.0) * rho)  # fmt: skip
    return np.array([x, 0, 0]), rho, [tip, body]


@pytest.mark.parametrize("seed", range(8))
def test_no_contact_on_the_cap_sinks_a_capsule(seed):
    """Seeded random tips: the pad takes in the tip capsule's end ball, and a contact
    anywhere on the cap (rim included) sinks no capsule more than OUTERMOST_MM."""
    rng = np.random.default_rng(seed)
    centre, rho, capsules = _random_tip(rng)
    grown, axis, half = fit_to_capsules(_frame(centre[0] + rho), centre, rho, 60.0, capsules)
    tip = capsules[0]
    assert grown == pytest.approx(max(rho, np.linalg.norm(tip.b - centre) + tip.radius))
    assert half >= 20.0  # a sphere tip on a finger keeps a usable cap
    assert axis @ [0, 0, 1.0] > -1e-9 and axis @ [1.0, 0, 0] > 0  # pad side, towards the tip
    cap = type("Cap", (), {"axis": axis, "half_angle": math.radians(half)})
    depths = [_plane_depth(capsules, centre, grown, u) for u in _cap_directions(cap, rng)]
    assert max(depths) <= OUTERMOST_MM + 1e-9


def test_directions_behind_the_tip_are_left_out():
    """A cylinder-ended tip (capsule as thick as the pad going back): the cap stays in
    front of the capsule's end, though the fit alone would reach 60 deg around a pad axis
    70 deg from the finger axis (130 deg: behind the end)."""
    centre, rho = np.array([30.0, 0, 0]), 10.0
    capsules = [Capsule((10, 0, 0), (30, 0, 0), rho)]
    _, axis, half = fit_to_capsules(_frame(40.0), centre, rho, 60.0, capsules)
    assert math.degrees(math.acos(axis[0])) + half <= 90.0 + 0.3


def test_without_capsules_the_fit_stands():
    T = np.eye(4)
    T[:3, 3] = (20, 0, 0)
    from prehension.hands.description import RawShape
    from prehension.hands.shapes import surface_points

    pts = surface_points(RawShape("sphere", "collision", T, (8.0,)), 800)
    plain, _ = fit_fingertip("f", _frame(28.0), pts, "x")
    tilt = math.radians(20)
    np.testing.assert_allclose(plain.axis, [math.sin(tilt), 0, math.cos(tilt)], atol=1e-12)
    assert math.degrees(plain.half_angle) == pytest.approx(60.0) and plain.radius == pytest.approx(8.0)
    # the sphere's own enclosing capsule (a point segment at its centre) changes nothing but the axis choice
    same, _ = fit_fingertip("f", _frame(28.0), pts, "x", [Capsule((20, 0, 0), (20, 0, 0), 8.0)])
    assert same.radius == pytest.approx(8.0) and math.degrees(same.half_angle) == pytest.approx(60.0)


@requires_hands
@pytest.mark.parametrize("path", [ALLEGRO, SVH], ids=["allegro", "svh"])
def test_shared_hands_pads_agree_with_their_capsules(path, rng):
    """Every fitted fingertip of the shared hands: no contact on its cap sinks a capsule
    of its link into a flat surface (the Allegro's tip capsule, r 12.37 mm round a 12.0 mm
    sphere, made every contact a collision before)."""
    hand = hand_from_urdf(path)
    for name, region in hand.regions.items():
        cap = region.region
        capsules = hand.links[hand.link_index(region.link)].collision
        assert math.degrees(cap.half_angle) >= 30.0, name
        depths = [_plane_depth(capsules, np.asarray(cap.center), cap.radius, u) for u in _cap_directions(cap, rng)]
        assert max(depths) <= OUTERMOST_MM + 1e-9, name
