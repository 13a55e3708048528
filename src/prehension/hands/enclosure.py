"""How well a link's capsules stand for its shapes: what they miss, how far they stick out.

Both numbers are measured per link, in its frame [mm], against every collision shape of
the link (:class:`~prehension.hands.description.RawShape`, or any point set for the SA
hand's published meshes):

* **miss**: the largest distance of a surface point of the shapes (a mesh's vertices, or
  points spread over a primitive) outside every capsule: 0 when the capsules enclose the
  link.  A capsule is convex, so a mesh whose vertices it holds lies inside it.
* **stick-out**: the largest distance from a point of the capsules' outer surface (their
  union's boundary, sampled about every 1 mm) to the link's shapes: exact for
  primitives (sphere, capsule, cylinder, box; an ellipsoid to its 20,000 surface samples),
  for a mesh to its nearest vertex (an upper bound by at most half an edge), 0 inside the
  convex hull of its vertices (a concave pocket of a mesh is not counted).

:func:`link_fit` returns both as a :class:`~prehension.hands.provenance.ShapeFit`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

from .description import RawShape
from .model import Capsule
from .provenance import ShapeFit

__all__ = ["capsule_gaps", "union_surface", "shape_distance", "link_fit", "fit_of_points"]

_SPACING_MM = 1.0  # spacing of the samples of the capsules' surface


def capsule_gaps(points, capsules) -> np.ndarray:
    """Distance of each of ``points (n, 3)`` outside the union of ``capsules`` [mm], (n,);
    negative inside."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    out = np.full(len(p), np.inf)
    for c in capsules:
        d = c.b - c.a
        dd = float(d @ d)
        s = np.clip((p - c.a) @ d / dd, 0.0, 1.0) if dd > 0 else np.zeros(len(p))
        out = np.minimum(out, np.linalg.norm(p - (c.a + s[:, None] * d), axis=1) - c.radius)
    return out


def _capsule_surface(c: Capsule) -> np.ndarray:
    """Points spread about every :data:`_SPACING_MM` over one capsule's surface, (m, 3)."""
    d = c.b - c.a
    length = float(np.linalg.norm(d))
    axis = d / length if length > 0 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    n_sphere = max(64, int(4 * math.pi * c.radius**2 / _SPACING_MM**2))
    k = np.arange(n_sphere) + 0.5
    z = 1.0 - 2.0 * k / n_sphere
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    ring = np.sqrt(1.0 - z * z)
    dirs = np.outer(ring * np.cos(phi), e1) + np.outer(ring * np.sin(phi), e2) + np.outer(z, axis)
    caps = c.radius * dirs + np.where((dirs @ axis >= 0)[:, None], c.b, c.a)
    n_around = max(16, int(2 * math.pi * c.radius / _SPACING_MM))
    n_along = max(2, int(length / _SPACING_MM) + 1) if length > 0 else 0
    if n_along == 0:
        return caps
    ang = np.linspace(0.0, 2 * math.pi, n_around, endpoint=False)
    circle = c.radius * (np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2))
    along = np.linspace(0.0, 1.0, n_along)[:, None] * d + c.a
    return np.concatenate([caps, (along[:, None, :] + circle[None, :, :]).reshape(-1, 3)])


def union_surface(capsules) -> np.ndarray:
    """Samples of the outer surface of the union of ``capsules``: each capsule's surface
    points that lie inside no other capsule, (m, 3) [mm]."""
    out = []
    for i, c in enumerate(capsules):
        pts = _capsule_surface(c)
        others = [o for j, o in enumerate(capsules) if j != i]
        if others:
            pts = pts[capsule_gaps(pts, others) >= -1e-9]
        out.append(pts)
    return np.concatenate(out) if out else np.zeros((0, 3))


def _box_distance(p: np.ndarray, half: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.maximum(np.abs(p) - half, 0.0), axis=1)


def shape_distance(shape: RawShape, points, mesh_vertices=None) -> np.ndarray:
    """Distance of ``points (n, 3)`` (link frame) to the solid of ``shape`` [mm], 0 inside
    (see the module docstring for how each kind is measured); ``mesh_vertices``: a mesh's
    vertices in the shape frame if already read."""
    T = shape.T_link_shape
    p = (np.asarray(points, dtype=float) - T[:3, 3]) @ T[:3, :3]  # shape frame
    size = shape.size
    if shape.kind == "sphere":
        return np.maximum(np.linalg.norm(p, axis=1) - size[0], 0.0)
    if shape.kind in ("capsule", "cylinder"):
        h = size[1] / 2
        if shape.kind == "capsule":
            q = p.copy()
            q[:, 2] = np.clip(q[:, 2], -h, h)
            return np.maximum(np.linalg.norm(p - q, axis=1) - size[0], 0.0)
        radial = np.maximum(np.linalg.norm(p[:, :2], axis=1) - size[0], 0.0)
        return np.hypot(radial, np.maximum(np.abs(p[:, 2]) - h, 0.0))
    if shape.kind == "box":
        return _box_distance(p, np.asarray(size, dtype=float) / 2)
    if shape.kind == "ellipsoid":
        s = np.asarray(size, dtype=float)
        k = 20000
        i = np.arange(k) + 0.5
        z = 1.0 - 2.0 * i / k
        phi = i * math.pi * (3.0 - math.sqrt(5.0))
        r = np.sqrt(1.0 - z * z)
        samples = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1) * s
        inside = np.sum((p / s) ** 2, axis=1) <= 1.0
        return np.where(inside, 0.0, cKDTree(samples).query(p)[0])
    verts = np.asarray(shape.vertices() if mesh_vertices is None else mesh_vertices, dtype=float)
    return points_distance(verts, p)


def points_distance(vertices: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance of ``p (n, 3)`` to the nearest of ``vertices (m, 3)``, 0 inside their convex hull."""
    dist = cKDTree(vertices).query(p)[0]
    try:
        planes = ConvexHull(vertices).equations  # (F, 4): n . x + b <= 0 inside
    except QhullError:  # flat or degenerate vertex sets: no interior
        return dist
    inside = np.max(p @ planes[:, :3].T + planes[:, 3], axis=1) <= 1e-9
    return np.where(inside, 0.0, dist)


def fit_of_points(capsules, surface: np.ndarray, distance, geometry: str) -> ShapeFit:
    """The :class:`ShapeFit` of ``capsules`` for a link whose surface samples are
    ``surface (n, 3)`` and whose solid's distance function is ``distance(points) -> (m,)``."""
    miss = float(max(0.0, np.max(capsule_gaps(surface, capsules)))) if len(surface) else 0.0
    boundary = union_surface(capsules)
    stick = float(np.max(distance(boundary))) if len(boundary) else 0.0
    return ShapeFit(geometry, round(miss, 2), round(stick, 2))


def link_fit(capsules, shapes: list[RawShape], surface: list[np.ndarray], geometry: str) -> ShapeFit:
    """The :class:`ShapeFit` of a link's ``capsules`` against its collision ``shapes``,
    whose surface points (link frame) are ``surface`` (one array per shape)."""
    def distance(points):
        return np.min([shape_distance(s, points) for s in shapes], axis=0)

    return fit_of_points(capsules, np.concatenate(surface), distance, geometry)
