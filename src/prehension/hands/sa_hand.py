"""The Schunk Anthropomorphic (SA) hand, a commercial DLR II hand (seed 000, sec. 5.1).

Sources, and how they disagree
------------------------------
The geometry comes from Table 3 of Rosales et al. (IJRR 2011), cross-checked against the
authors' own CuikSuite world files (``shared/cuik-ijrr``), which are what their solver
actually ran.  Where the two disagree we follow the world files:

* middle finger base: Table 3 says z = 145.43 mm; the files say **150.15** mm.
* ring/index base y: Table 3 rounds to +/-40.16; the files give **+/-40.165** mm.
* ring and index first-axis reference vectors: the files tilt them by about 2 degrees
  about the palm x axis, (0, -0.99941, 0.034301) and (0, -0.99937, -0.035485): at zero
  abduction those two fingers lean about 2 degrees towards the middle finger.  Table 3 is
  silent on this; we keep the files' numbers.
* finger flexion axes: Table 3 writes (0, 1, 0); the files write **(0, -1, 0)** in both
  links, which makes positive angles flex towards the front of the palm (+x), the side
  the fingertip pads face.  We use the files' sign.
* thumb base axis: Table 3 gives v10 = (1, 0, 0) in F10; the files give **(-1, 0, 0)**
  (with u10 = (0, 0, -1) in the palm, in both).
* universal-joint angle 2: measured as in the 2011 CuikSuite release (see
  ``shared/cuik-ijrr/README.md``): a positive angle flexes the proximal phalanx towards +x,
  the same side as the distal joints.

Limits are the mechanical ones of sec. 5.1 (not the files' wider ranges): abduction
[-15, 15] deg, proximal flexion [-4, 75] deg, both distal revolute joints [4, 75] deg,
thumb base [0, 90] deg; the thumb's universal joint has the same limits as the fingers'.
The two distal joints of each finger are coupled by equal angles (sec. 5.1).

Fingertips are spheres of radius 13 mm centred 20 mm beyond the distal joint, with a
contact cap about m = (0.14, 0, 0.99) (normalised), as in the files; we give the cap a
half-angle of 60 deg (the files use 60 or 90 deg depending on the task).  The palm region
is a sphere cap of radius 13 mm whose surface touches the palm's front face (x = 20.55 mm)
at (20.55, -0.053, 117.348), axis +x, half-angle 60 deg, as in the teapot files.

Collision shapes are capsules inside the published link meshes (the CuikSuite bodies
``p1``-``p4``, ``b2``, ``b4``, ``p0thumb``, ``palmSAH``, ``acs*palm``; radius 10-12 mm for the
phalanges, 20 mm for the palm slabs).  Measured against those meshes (each link's
:attr:`~prehension.hands.model.Link.fit`, re-measured by ``tests/test_sa_geometry.py``
from ``../shared/cuik-ijrr/bodies``), they miss up to 10.5 mm of a distal phalanx, 10 mm of
a middle one, 16 mm of a proximal one, 24 mm of the thumb base and 48 mm of the palm:
a clear capsule does not prove a clear link (``schunk-sa-enclosing`` is the hand whose
capsules do, :mod:`prehension.hands.sa_enclosing`).  None sticks out of its link's
published shape: the palm's slabs and the thumb base's capsule, which did by 16.5 and
22.8 mm, end where the published shapes end (:data:`PALM_SLABS`, docs/hands.md).
"""

from __future__ import annotations

import numpy as np

from ..geometry.regions import SphereCap
from .model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link
from .provenance import ShapeFit

__all__ = ["schunk_sa_hand", "SA_LINK_FITS", "SA_FINGER_BASES", "SA_TIP_RADIUS_MM", "SA_TIP_CENTER_MM", "SA_TIP_AXIS"]

DEG = np.pi / 180.0

# Finger base centres in the palm frame [mm] and the reference vector of the first axis
# (palm frame) at zero abduction: the files' numbers (see the module docstring).
SA_FINGER_BASES = {
    "ring": ((-4.3, -40.165, 145.43), (0.0, -0.99941, 0.034301)),
    "middle": ((-4.3, 0.0, 150.15), (0.0, -1.0, 0.0)),
    "index": ((-4.3, 40.165, 145.43), (0.0, -0.99937, -0.035485)),
}
PROXIMAL_LENGTH_MM = 67.8  # proximal joint to middle joint (Table 3, p_2 in F_1)
MIDDLE_LENGTH_MM = 30.0  # middle joint to distal joint (Table 3, p_3 in F_2)
FLEXION_AXIS = (0.0, -1.0, 0.0)  # the files' sign: positive flexes towards palm +x

THUMB_BASE_CENTER_MM = (-3.0, 27.1, 0.0)  # Table 3, p_10 in F_0 (files agree)
THUMB_BASE_AXIS_PALM = (0.0, 0.0, -1.0)  # Table 3, u_10 in F_0 (files agree)
THUMB_BASE_AXIS_LINK = (-1.0, 0.0, 0.0)  # files; Table 3 prints (1, 0, 0)
THUMB_BASE_REF_PALM = (0.0, -1.0, 0.0)  # files: angle-zero reference in the palm
THUMB_BASE_REF_LINK = (0.0, 0.0, 1.0)  # files: angle-zero reference in the thumb base
THUMB_U_CENTER_MM = (97.0, 6.0, -87.0)  # Table 3, p_11 in F_10 (files agree)
THUMB_U_AXIS = (np.cos(55 * DEG), 0.0, np.sin(55 * DEG))  # Table 3, u_11 in F_10
THUMB_U_REF = (0.0, 1.0, 0.0)  # files: reference of angle 1, in F_10

SA_TIP_RADIUS_MM = 13.0  # fingertip sphere radius (files: rho = 13)
SA_TIP_CENTER_MM = (20.0, 0.0, 0.0)  # sphere centre in the distal link frame (files)
SA_TIP_AXIS = (0.14, 0.0, 0.99)  # contact-cap axis m in the distal frame (files), normalised on use
SA_TIP_HALF_ANGLE = 60 * DEG  # our choice (files: 60 or 90 deg per task)
PALM_FACE_X_MM = 20.55  # palm front face (files: qpx = 20.550 - rho)
PALM_CONTACT_MM = (PALM_FACE_X_MM - SA_TIP_RADIUS_MM, -0.053, 117.348)

ABDUCTION = (-15 * DEG, 15 * DEG)  # sec. 5.1
PROXIMAL_FLEXION = (-4 * DEG, 75 * DEG)  # sec. 5.1
DISTAL_FLEXION = (4 * DEG, 75 * DEG)  # sec. 5.1, both distal revolute joints
THUMB_BASE = (0 * DEG, 90 * DEG)  # sec. 5.1


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _zero_rotation(axis_parent, ref_parent, axis_child, ref_child) -> np.ndarray:
    """R0 that maps the child's (axis, reference) onto the parent's (axis, reference)."""
    a_p, r_p = _unit(axis_parent), _unit(ref_parent)
    a_c, r_c = _unit(axis_child), _unit(ref_child)
    A = np.column_stack([a_p, r_p, np.cross(a_p, r_p)])
    B = np.column_stack([a_c, r_c, np.cross(a_c, r_c)])
    return A @ B.T


def _universal(name, parent, child, centre, u_parent, ref_parent) -> Joint:
    """The SA finger base: u in the parent, v = y of the child; 2011 angle-2 sign.

    At zero angles the child's y axis lies along ``ref_parent`` and its z axis along u.
    Angle 2 turns the child about -y (child frame), i.e. flexes towards z (= u, the
    front of the palm for the fingers), as the 2011 CuikSuite release measured it.
    """
    v_child, ref_child = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    R0 = _zero_rotation(ref_parent, u_parent, v_child, ref_child)  # R0 v = ref, R0 (0,0,1) = u
    return Joint(
        name, "universal", parent, child, centre, (0, 0, 0), u_parent, R0,
        (f"{name}_abd", f"{name}_flex"), (ABDUCTION[0], PROXIMAL_FLEXION[0]),
        (ABDUCTION[1], PROXIMAL_FLEXION[1]), axis_in_child=(0.0, -1.0, 0.0),
    )  # fmt: skip


def _revolute(name, parent, child, length) -> Joint:
    return Joint(
        name, "revolute", parent, child, (length, 0, 0), (0, 0, 0), FLEXION_AXIS, np.eye(3),
        (name,), (DISTAL_FLEXION[0],), (DISTAL_FLEXION[1],),
    )  # fmt: skip


# How the capsules stand for the published meshes (misses, sticks out) [mm]: measured by
# tests/test_sa_geometry.py (hands/enclosure.py, mesh distances to the nearest vertex).
_PUBLISHED = "published mesh (CuikSuite bodies)"
SA_LINK_FITS = {
    "palm": ShapeFit(_PUBLISHED, 48.31, 0.0),
    "thumb_base": ShapeFit(_PUBLISHED, 24.4, 0.0),
    "proximal": ShapeFit(_PUBLISHED, 16.17, 0.0),
    "middle": ShapeFit(_PUBLISHED, 9.95, 0.0),
    "distal": ShapeFit(_PUBLISHED, 10.54, 0.0),
}


def _phalanx_links(finger: str) -> list[Link]:
    return [
        Link(f"{finger}_proximal", (Capsule((8, 0, 0), (60, 0, 0), 12.0),), SA_LINK_FITS["proximal"]),
        Link(f"{finger}_middle", (Capsule((4, 0, 0), (26, 0, 0), 11.0),), SA_LINK_FITS["middle"]),
        Link(f"{finger}_distal", (Capsule((3, 0, 0), (20, 0, 0), 10.0),), SA_LINK_FITS["distal"]),
    ]


def _finger_joints(finger: str, base_link: str, centre, u_parent, ref_parent) -> list[Joint]:
    return [
        _universal(f"{finger}_mcp", base_link, f"{finger}_proximal", centre, u_parent, ref_parent),
        _revolute(f"{finger}_pip", f"{finger}_proximal", f"{finger}_middle", PROXIMAL_LENGTH_MM),
        _revolute(f"{finger}_dip", f"{finger}_middle", f"{finger}_distal", MIDDLE_LENGTH_MM),
    ]


def _thumb_base_joint() -> Joint:
    R0 = _zero_rotation(THUMB_BASE_AXIS_PALM, THUMB_BASE_REF_PALM, THUMB_BASE_AXIS_LINK, THUMB_BASE_REF_LINK)
    return Joint(
        "thumb_base", "revolute", "palm", "thumb_base", THUMB_BASE_CENTER_MM, (0, 0, 0),
        THUMB_BASE_AXIS_PALM, R0, ("thumb_base",), (THUMB_BASE[0],), (THUMB_BASE[1],),
    )  # fmt: skip


# The palm's three slabs (x = -2, r = 20, at z = 15, 55, 95 as in the paper) end where the
# published palm ends: the paper's y = +/-45 put their round ends 3.5-16 mm outside it
# (the palm narrows towards the wrist, and is wider on the thumb's side, +y).  Each end is
# the farthest (rounded in to 0.5 mm) at which the capsule stays inside the hulls of the
# four palm bodies (measured as SA_LINK_FITS is; docs/hands.md).
PALM_SLABS = ((15.0, -27.5, 40.0), (55.0, -39.0, 43.0), (95.0, -39.5, 41.0))  # (z, y from, y to) [mm]
# The thumb base: the paper's capsule (10, 0, -25)-(90, 4, -78), r = 14, shortened along
# its axis by 19.5 mm at the palm end and 5.5 mm at the far end, where it stuck out of the
# published thumb base by up to 22.8 mm.
THUMB_BASE_CAPSULE = ((26.24, 0.81, -35.76), (85.42, 3.77, -74.97), 14.0)


def _palm_link() -> Link:
    slabs = tuple(Capsule((-2, y0, z), (-2, y1, z), 20.0) for z, y0, y1 in PALM_SLABS)
    return Link("palm", slabs, SA_LINK_FITS["palm"])


def _tip_region(finger: str) -> HandRegion:
    cap = SphereCap(SA_TIP_CENTER_MM, SA_TIP_RADIUS_MM, SA_TIP_AXIS, SA_TIP_HALF_ANGLE)
    return HandRegion(f"{finger}_distal", cap)


def schunk_sa_hand() -> Hand:
    """The built-in SA hand: 14 links, 13 joints (9 R + 4 U), 17 angles, 4 couplings."""
    links = [_palm_link()]
    joints: list[Joint] = []
    fingers = []
    for finger, (centre, ref) in SA_FINGER_BASES.items():
        links += _phalanx_links(finger)
        joints += _finger_joints(finger, "palm", centre, (1.0, 0.0, 0.0), ref)
        fingers.append(Finger(finger, tuple(l.name for l in links[-3:])))
    links.append(Link("thumb_base", (Capsule(*THUMB_BASE_CAPSULE),), SA_LINK_FITS["thumb_base"]))
    links += _phalanx_links("thumb")
    joints.append(_thumb_base_joint())
    joints += _finger_joints("thumb", "thumb_base", THUMB_U_CENTER_MM, THUMB_U_AXIS, THUMB_U_REF)
    fingers.append(Finger("thumb", ("thumb_base", "thumb_proximal", "thumb_middle", "thumb_distal")))
    couplings = [Coupling(f"{f}_dip", f"{f}_pip") for f in ("ring", "middle", "index", "thumb")]
    regions = {f"{f}_tip": _tip_region(f) for f in ("ring", "middle", "index", "thumb")}
    regions["palm"] = HandRegion(
        "palm", SphereCap(PALM_CONTACT_MM, SA_TIP_RADIUS_MM, (1.0, 0.0, 0.0), SA_TIP_HALF_ANGLE)
    )
    return Hand("schunk-sa", tuple(links), tuple(joints), tuple(couplings), tuple(fingers), regions)
