"""The SA hand with collision capsules that enclose its published link shapes (issue 26 item 2).

A variant of :func:`~prehension.hands.sa_hand.schunk_sa_hand` (built-in hand
``schunk-sa-enclosing``): the same kinematics, fingertip and palm regions, but each link's
capsules **enclose** the link's published mesh (the CuikSuite bodies, read at fitting time
only: ``python scripts/sa_capsules.py`` prints these numbers), so that a capsule clear of
the object proves the link clear.  Exception: within 60 degrees (the caps' half-angle) of
a pad's axis the pad sphere (13 mm) stands for the link's surface, and the capsules hold
the sphere there, not the mesh; the fingertip and palm pad spheres are themselves capsules
of their links.  What that leaves out -- the pad model's error -- is measured in
docs/hands.md (the distal mesh lies outside the 13 mm sphere by 0.8 mm within 20 degrees of
the pad axis, 3.7 mm at 30 degrees, 5.5 mm at 60 degrees).

Each link records what its capsules miss (0) and how far they stick out
(:attr:`~prehension.hands.model.Link.fit`; re-measured from ``../shared`` by
``tests/test_sa_geometry.py``).  Link pairs whose capsules overlap at the rest pose are
left out of self-collision checks, as for a hand read from a file.

Not the default: measured on the nine built-in tasks (``benchmarks/sa_enclosing.py``,
docs/hands.md), the enclosing capsules reach past the pad sphere near every contact.
"""

from __future__ import annotations

from dataclasses import replace

from .assemble import with_rest_exclusions
from .model import Capsule, Hand, Link
from .provenance import ShapeFit
from .sa_hand import schunk_sa_hand

__all__ = ["schunk_sa_hand_enclosing", "with_enclosing_capsules", "SA_ENCLOSING_CAPSULES", "SA_ENCLOSING_FITS"]

_MESH = "published mesh (CuikSuite bodies)"
_PAD = "published mesh (CuikSuite bodies), pad sphere within 60 deg of the pad axis"

# Per link kind, in the link frame [mm]: scripts/sa_capsules.py (k-means parts, each the
# least-volume enclosing capsule found; radii rounded up; k = 3, 3, 2, 3, 3).  The distal
# set reaches least past the pad's tangent planes for contacts within 20 degrees of its
# axis (also the best of 120 partitions, k = 2..6, tried while choosing): still 1.7 mm past
# the sphere at the axis, 4.4 mm at 20 degrees.
SA_ENCLOSING_CAPSULES = {
    "palm": (
        Capsule((7.55, -0.05, 117.35), (7.55, -0.05, 117.35), 13.01),  # the palm pad's sphere
        Capsule((-7.89, 24.07, 58.07), (-7.89, 24.07, 120.83), 42.69),
        Capsule((-9.75, -29.06, 77.41), (-13.87, -22.28, 128.9), 41.25),
        Capsule((-10.84, 14.58, 21.13), (-3.14, -19.08, 31.79), 52.55),
    ),
    "thumb_base": (
        Capsule((40.88, 0.55, -52.75), (32.12, 1.05, -41.26), 33.36),
        Capsule((83.62, 5.0, -59.12), (75.28, 7.63, -54.64), 27.87),
        Capsule((82.33, 5.42, -88.82), (50.61, 3.99, -73.76), 22.3),
    ),
    "proximal": (
        Capsule((33.28, 0.06, 0.84), (61.02, 0.06, 0.84), 20.96),
        Capsule((13.29, 0.05, -0.31), (9.87, -0.04, 7.14), 25.55),
    ),
    "middle": (
        Capsule((1.73, 8.26, -2.15), (12.83, 3.85, -0.93), 15.0),
        Capsule((1.04, -8.2, -2.17), (8.97, -4.8, -0.75), 14.71),
        Capsule((23.23, -0.76, -1.48), (28.68, 0.76, -0.14), 16.57),
    ),
    "distal": (
        Capsule((20.0, 0.0, 0.0), (20.0, 0.0, 0.0), 13.01),  # the fingertip pad's sphere
        Capsule((26.96, -0.01, -2.14), (28.0, -0.2, -1.29), 13.89),
        Capsule((1.15, -6.83, -2.12), (-1.4, 3.84, -1.52), 13.51),
        Capsule((14.08, -0.34, -1.63), (11.82, 0.66, -1.52), 17.2),
    ),
}
SA_ENCLOSING_FITS = {  # misses, sticks out [mm]: measured by scripts/sa_capsules.py, re-measured by the tests
    "palm": ShapeFit(_PAD, 0.0, 41.42),
    "thumb_base": ShapeFit(_MESH, 0.0, 18.49),
    "proximal": ShapeFit(_MESH, 0.0, 15.29),
    "middle": ShapeFit(_MESH, 0.0, 12.52),
    "distal": ShapeFit(_PAD, 0.0, 10.46),
}


def _kind(link: str) -> str:
    return link if link in ("palm", "thumb_base") else link.rsplit("_", 1)[1]


def with_enclosing_capsules(hand: Hand) -> Hand:
    """An SA hand (the built-in one, or a task's copy with its own regions and limits)
    with enclosing capsules, named ``schunk-sa-enclosing``, and the link pairs that
    overlap at the rest pose excluded from self-collision checks."""
    links = tuple(Link(l.name, SA_ENCLOSING_CAPSULES[_kind(l.name)], SA_ENCLOSING_FITS[_kind(l.name)]) for l in hand.links)
    return with_rest_exclusions(replace(hand, name="schunk-sa-enclosing", links=links, collision_exclusions=()))


def schunk_sa_hand_enclosing() -> Hand:
    """The SA hand (:func:`~prehension.hands.sa_hand.schunk_sa_hand`) with enclosing capsules."""
    return with_enclosing_capsules(schunk_sa_hand())
