"""A two-joint 'pincer' and tasks on it whose feasibility is known by hand.

The pincer: a palm with a pad at (10, 0, 100) facing +x, and a planar finger (joints at
(0, 0, 50) and 40 mm further, both flexing towards +x about +y, limits [0, 90] deg) with
a fingertip sphere of radius 8 mm, 30 mm beyond the second joint, whose contact cap faces
+x (half-angle 90 deg).  The object is two points d apart along its x axis: A (normal -x)
touched by the pad, B (normal -x) touched by the fingertip.

The pad fixes A at the pad and the object's x axis along the palm's, so B's contact point
is at (10 + d, 0, 100) and the fingertip centre at (2 + d, 0, 100), which the finger
reaches iff its distance from the first joint, sqrt((2 + d)^2 + 50^2), is at most 70 mm:
**infeasible for d > 47 mm**, feasible up to it (the cone allows it: the finger turns by
less than 90 deg) down to some lower bound: for small d the first joint would have to
turn below its limit (d = 20 mm needs j1 = -8.9 deg), so the tests use d from 30 to 46 mm.
"""

from __future__ import annotations

import numpy as np

from prehension.geometry.regions import PointRegion, SphereCap
from prehension.hands.model import Capsule, Finger, Hand, HandRegion, Joint, Link
from prehension.objects.meshes import Box
from prehension.objects.model import GraspObject
from prehension.objects.solid import PrimitiveSolid
from prehension.tasks.model import Contact, Task

FEASIBLE_UP_TO_MM = np.sqrt(70.0**2 - 50.0**2) - 2.0  # 46.99


def pincer_hand() -> Hand:
    half_pi = np.pi / 2
    j1 = Joint("j1", "revolute", "palm", "prox", (0, 0, 50), (0, 0, 0), (0, 1, 0), np.eye(3), ("j1",), (0.0,), (half_pi,))
    j2 = Joint("j2", "revolute", "prox", "dist", (0, 0, 40), (0, 0, 0), (0, 1, 0), np.eye(3), ("j2",), (0.0,), (half_pi,))
    regions = {
        "tip": HandRegion("dist", SphereCap((0, 0, 30), 8.0, (1, 0, 0), half_pi)),
        "pad": HandRegion("palm", PointRegion((10, 0, 100), (1, 0, 0))),
    }
    links = (Link("palm"), Link("prox"), Link("dist"))
    return Hand("pincer", links, (j1, j2), (), (Finger("f", ("prox", "dist")),), regions)


def pincer_task(d: float) -> Task:
    obj = GraspObject("two-points", {"A": PointRegion((0, 0, 0), (-1, 0, 0)), "B": PointRegion((d, 0, 0), (-1, 0, 0))})
    return Task(f"pincer-{d:g}", pincer_hand(), obj, (Contact("pad", "A"), Contact("tip", "B")), ("f",))


# -- the paddle and the pit: infeasible only because of the object --------------------------
def paddle_hand(proud_mm: float = 0.0) -> Hand:
    """A palm capsule 100 mm long with a pad at its tip facing +x, and one idle finger.

    A small sphere at the palm's tip holds the pad (a point) and reaches ``proud_mm``
    beyond the pad's plane x = 10 mm: a point pad has no volume and excuses nothing, so a
    proud sphere is penetration wherever the pad touches a flat floor."""
    half_pi = np.pi / 2
    palm = Link("palm", (Capsule((0, 0, 0), (0, 0, 90), 10.0), Capsule((5.5 + proud_mm, 0, 97), (5.5 + proud_mm, 0, 97), 4.5)))
    finger = Link("f1", (Capsule((0, 0, 0), (0, 0, 30), 6.0),))
    joint = Joint("j1", "revolute", "palm", "f1", (0, 0, 0), (0, 0, 0), (0, 1, 0), np.eye(3), ("j1",), (0.0,), (half_pi,))
    regions = {"pad": HandRegion("palm", PointRegion((10, 0, 100), (1, 0, 0)))}
    return Hand("paddle", (palm, finger), (joint,), (), (Finger("f", ("f1",)),), regions)


def pit_task(half_width: float, proud_mm: float = 0.0) -> Task:
    """The pad must touch the floor of a square pit (``2 half_width`` wide, 30 mm deep,
    opening towards -x): the palm then lies 10 mm above the floor, in the walls."""
    h, long = half_width, 2 * half_width + 160.0
    walls = (Box((-15.0, 0.0, h + 40.0), (30.0, long, 80.0)), Box((-15.0, 0.0, -h - 40.0), (30.0, long, 80.0)),
             Box((-15.0, h + 40.0, 0.0), (30.0, 80.0, 2 * h)), Box((-15.0, -h - 40.0, 0.0), (30.0, 80.0, 2 * h)))  # fmt: skip
    solid = PrimitiveSolid((Box((30.0, 0.0, 0.0), (60.0, long + 40.0, long + 40.0)),) + walls)
    obj = GraspObject("pit", {"floor": PointRegion((0, 0, 0), (-1, 0, 0))}, solid=solid)
    return Task(f"pit-{2 * h:g}", paddle_hand(proud_mm), obj, (Contact("pad", "floor"),), ())
