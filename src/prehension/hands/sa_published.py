"""The SA hand's published link shapes, as the enclosing capsules must hold them (issue 26 item 2).

The shapes are the CuikSuite bodies (``shared/cuik-ijrr/bodies``, GPL): never shipped,
read only where they are present, to fit (``scripts/sa_capsules.py``) and to re-measure
(``tests/test_sa_geometry.py``) the capsules of :mod:`prehension.hands.sa_enclosing`.
Their frames are the links' frames (the world files place them on the same joints).

Per link kind, the shape is its meshes' vertices, except within :data:`PAD_HALF_ANGLE_DEG`
of a pad's axis (the fingertip's and the palm's 13 mm sphere caps): there the pad sphere
stands for the link's surface (:func:`published_shape`), so the capsules hold the
sphere's cap, and the distance to the shape is the distance to the sphere.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .enclosure import points_distance
from .sa_hand import PALM_CONTACT_MM, SA_TIP_AXIS, SA_TIP_CENTER_MM, SA_TIP_RADIUS_MM
from .shapes import _sphere_dirs

__all__ = ["PARTS", "PADS", "PAD_HALF_ANGLE_DEG", "off_vertices", "in_pad_cone", "published_shape"]

PARTS = {  # link kind -> CuikSuite body names
    "palm": ("palmSAH", "acs1palm", "acs2palm", "acs3palm"),
    "thumb_base": ("p0thumb",),
    "proximal": ("p1", "p2", "b2"),
    "middle": ("p3",),
    "distal": ("p4", "b4"),
}
PAD_HALF_ANGLE_DEG = 60.0  # the caps' half-angle: where the solvers may put a contact
PADS = {  # link kind -> (sphere centre, radius, axis) in the link frame [mm]
    "distal": (SA_TIP_CENTER_MM, SA_TIP_RADIUS_MM, SA_TIP_AXIS),
    "palm": (PALM_CONTACT_MM, SA_TIP_RADIUS_MM, (1.0, 0.0, 0.0)),
}


def off_vertices(path: Path) -> np.ndarray:
    """The vertices (n, 3) of an OFF file [its units: mm for the CuikSuite bodies]."""
    rows = [r for r in Path(path).read_text().splitlines() if r.strip() and not r.startswith("#")]
    n = int(rows[1].split()[0])
    return np.array([[float(x) for x in r.split()[:3]] for r in rows[2 : 2 + n]])


def in_pad_cone(points: np.ndarray, kind: str) -> np.ndarray:
    """(n,) bool: ``points (n, 3)`` within the pad's cone (none for a link without a pad)."""
    if kind not in PADS:
        return np.zeros(len(points), dtype=bool)
    c, _, m = PADS[kind]
    d = points - np.asarray(c, dtype=float)
    m = np.asarray(m, dtype=float) / np.linalg.norm(m)
    return d @ m >= math.cos(math.radians(PAD_HALF_ANGLE_DEG)) * np.linalg.norm(d, axis=1)


def published_shape(kind: str, meshes: list[np.ndarray]):
    """``(points (n, 3), distance)``: the points the capsules of a link of ``kind`` must
    hold, and the shape's distance function ``(m, 3) -> (m,)`` [mm] (0 inside)."""
    verts = np.concatenate(meshes)
    pts = verts[~in_pad_cone(verts, kind)]
    if kind in PADS:
        c, rho, _ = PADS[kind]
        cap = np.asarray(c, dtype=float) + rho * _sphere_dirs(4000)
        pts = np.concatenate([pts, cap[in_pad_cone(cap, kind)]])

    def distance(q):
        d = np.min([points_distance(m, q) for m in meshes], axis=0)
        if kind in PADS:  # in the cone the shape is the pad sphere
            c, rho, _ = PADS[kind]
            ds = np.maximum(np.linalg.norm(q - np.asarray(c, dtype=float), axis=1) - rho, 0.0)
            d = np.where(in_pad_cone(q, kind), ds, d)
        return d

    return pts, distance
