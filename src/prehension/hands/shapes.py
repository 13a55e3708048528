"""Shapes of hand files -> collision capsules, and surface points for fingertip fits.

Capsules **enclose** the shapes they stand for, so that a capsule clear of the object or
of another link proves the link clear (all in the shape's own frame, mm; what they miss
and how far they stick out is measured by :mod:`prehension.hands.enclosure`):

- sphere: the sphere itself (a capsule with ``a == b``);
- capsule: itself;
- cylinder (along z): the capsule of least volume along the axis holding both rims
  (a flat disc becomes the sphere through them);
- box with sides ``long >= mid >= short``: ``n = ceil(mid/short)`` (at most 8) parallel
  capsules along the long side, each the least-volume capsule holding one slab
  ``long x mid/n x short`` (its corners);
- ellipsoid: a capsule along its long axis holding dense surface samples, grown by
  their spacing (:func:`ellipsoid_capsule`);
- mesh: the least-volume capsule found over 306 axes that holds every vertex
  (:func:`mesh_capsule`; a capsule is convex, so it holds the mesh).

:func:`surface_points` samples the surface of any shape (the vertices of a mesh), for
the fingertip fits of :mod:`prehension.hands.fingertips` and the enclosure measures.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..objects.mesh_io import read_triangles
from .description import RawShape
from .model import Capsule

__all__ = [
    "shape_capsules", "surface_points", "mesh_capsule", "read_mesh_vertices", "move_capsule",
    "cylinder_capsule", "box_capsules", "ellipsoid_capsule",
]  # fmt: skip

_MAX_BOX_CAPSULES = 8


def move_capsule(cap: Capsule, T: np.ndarray) -> Capsule:
    """The capsule moved by the rigid transform ``T`` (4, 4)."""
    R, t = T[:3, :3], T[:3, 3]
    return Capsule(R @ cap.a + t, R @ cap.b + t, cap.radius)


def _enclosing_segment(t: np.ndarray, d: np.ndarray, radius: float) -> tuple[float, float]:
    """The shortest segment ``[s0, s1]`` on an axis whose capsule of ``radius`` holds every
    point at axial coordinate ``t (n,)`` and distance ``d (n,)`` from the axis (``d <= radius``).

    A point is inside when the segment meets ``[t - h, t + h]``, ``h = sqrt(radius^2 - d^2)``;
    the shortest such segment runs from ``min(t + h)`` to ``max(t - h)``, or is the point
    between them when those cross (a sphere holds every point then).
    """
    h = np.sqrt(np.maximum(radius * radius - d * d, 0.0))
    s0, s1 = float(np.min(t + h)), float(np.max(t - h))
    return (s0, s1) if s0 <= s1 else ((s0 + s1) / 2,) * 2


def _smallest_enclosing(t: np.ndarray, d: np.ndarray) -> tuple[float, float, float]:
    """``(s0, s1, radius)`` of the capsule of least volume about an axis that holds every
    point ``(t, d)`` (see :func:`_enclosing_segment`): radii from ``max(d)`` to 1.6 times it
    are tried, then a finer grid around the best (a larger radius shortens the segment)."""
    d_max = float(np.max(d))
    step = 0.6 * d_max / 24
    best = None
    for radii in (d_max + step * np.arange(25), None):
        if radii is None:  # refine around the best of the coarse grid
            radii = np.clip(best[3] + step * np.linspace(-1.0, 1.0, 21), d_max, None)
        for radius in radii + 1e-9:
            s0, s1 = _enclosing_segment(t, d, radius)
            volume = math.pi * radius**2 * (s1 - s0) + 4.0 / 3.0 * math.pi * radius**3
            if best is None or volume < best[0]:
                best = (volume, s0, s1, radius)
    return best[1], best[2], best[3]


def _capsule_on_axis(points: np.ndarray, axis: np.ndarray, centre: np.ndarray) -> Capsule:
    """The smallest capsule along ``axis`` through ``centre`` that holds ``points (n, 3)``."""
    X = points - centre
    t = X @ axis
    d = np.linalg.norm(X - t[:, None] * axis, axis=1)
    s0, s1, radius = _smallest_enclosing(t, d)
    return Capsule(centre + s0 * axis, centre + s1 * axis, radius)


def cylinder_capsule(radius: float, length: float) -> list[Capsule]:
    """The smallest capsule along z that encloses the cylinder (its two rims, exactly)."""
    s0, s1, rho = _smallest_enclosing(np.array([-length / 2, length / 2]), np.array([radius, radius]))
    return [Capsule((0, 0, s0), (0, 0, s1), rho)]


def box_capsules(size) -> list[Capsule]:
    """``n = ceil(mid/short)`` (at most 8) parallel capsules along the long side, each
    enclosing one slab ``long x mid/n x short`` of the box (its eight corners)."""
    size = np.asarray(size, dtype=float)
    if not np.all(size > 0):
        raise ValueError(f"box sizes must be positive, got {size.tolist()} mm")
    long_ax, mid_ax, short_ax = np.argsort(-size, kind="stable")
    n = min(_MAX_BOX_CAPSULES, max(1, math.ceil(size[mid_ax] / size[short_ax] - 1e-9)))
    half = size / 2
    half[mid_ax] /= n
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    e_long, e_mid = np.eye(3)[long_ax], np.eye(3)[mid_ax]
    offsets = (np.arange(n) - (n - 1) / 2) * size[mid_ax] / n
    return [_capsule_on_axis(corners + s * e_mid, e_long, s * e_mid) for s in offsets]


def ellipsoid_capsule(semi_axes) -> list[Capsule]:
    """The smallest capsule along the ellipsoid's long axis that holds 20,000 points spread
    over its surface, its radius grown by the largest gap between neighbouring samples'
    radii so that the surface between the samples stays inside."""
    s = np.asarray(semi_axes, dtype=float)
    if not np.all(s > 0):
        raise ValueError(f"ellipsoid semi-axes must be positive, got {s.tolist()} mm")
    e = np.eye(3)[int(np.argmax(s))]
    pts = _sphere_dirs(20000) * s
    cap = _capsule_on_axis(pts, e, np.zeros(3))
    return [Capsule(cap.a, cap.b, cap.radius + 0.002 * float(s.max()))]


def _axis_candidates(X: np.ndarray) -> np.ndarray:
    """Unit axes worth trying for a point cloud ``X (n, 3)`` (centred): its three principal
    axes, the three axes of its own frame (meshes are often drawn along them) and 300
    directions spread over a hemisphere (an almost isotropic cloud has no meaningful
    principal axis), (306, 3)."""
    half = _sphere_dirs(600)
    half = half[half[:, 2] > 0]
    return np.concatenate([np.linalg.svd(X, full_matrices=False)[2], np.eye(3), half])


def _plane_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def _circle_centre(X: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Centre (3,), in the plane through the origin normal to ``axis``, of a small circle
    holding the projections of ``X (n, 3)``: the middle of their bounding square, then
    moved towards the farthest point (Badoiu-Clarkson iterations); the better of the two."""
    e1, e2 = _plane_basis(axis)
    uv = np.stack([X @ e1, X @ e2], axis=1)
    box = (uv.min(axis=0) + uv.max(axis=0)) / 2
    c = box
    for k in range(1, 80):
        far = uv[np.argmax(np.sum((uv - c) ** 2, axis=1))]
        c = c + (far - c) / (k + 1)
    best = min((c, box), key=lambda z: np.max(np.sum((uv - z) ** 2, axis=1)))
    return best[0] * e1 + best[1] * e2


def _rough_volumes(X: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """For each of ``axes (k, 3)``, the volume of the capsule of radius ``max(d)`` about
    the axis through the middle of the projections' bounding square, (k,) (a cheap score)."""
    t = X @ axes.T  # (n, k) axial coordinates
    out = np.empty(len(axes))
    for i, axis in enumerate(axes):
        e1, e2 = _plane_basis(axis)
        uv = np.stack([X @ e1, X @ e2], axis=1)
        d = np.linalg.norm(uv - (uv.min(axis=0) + uv.max(axis=0)) / 2, axis=1)
        r = float(d.max()) + 1e-9
        s0, s1 = _enclosing_segment(t[:, i], d, r)
        out[i] = math.pi * r * r * (s1 - s0) + 4.0 / 3.0 * math.pi * r**3
    return out


def _volume(cap: Capsule) -> float:
    return math.pi * cap.radius**2 * float(np.linalg.norm(cap.b - cap.a)) + 4.0 / 3.0 * math.pi * cap.radius**3


def mesh_capsule(points) -> Capsule:
    """The capsule of least volume found that holds every one of ``points (n, 3)``.

    Every axis of :func:`_axis_candidates` is scored cheaply (:func:`_rough_volumes`); the
    five best are fitted in full: through the centre of a small circle holding the points'
    projections, with the radius that gives the least volume (:func:`_smallest_enclosing`).
    A capsule is convex, so holding a mesh's vertices it holds the whole mesh.  An almost
    isotropic cloud (a spherical fingertip) gets the sphere or short capsule that fits,
    never a segment collapsed to the centroid with a radius that misses the tip.
    """
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    if len(pts) < 2:
        raise ValueError("the mesh has fewer than 2 distinct vertices")
    centre = pts.mean(axis=0)
    X = pts - centre
    if np.linalg.svd(X, compute_uv=False)[1] <= 1e-9 * max(1.0, float(np.abs(X).max())):
        raise ValueError("the mesh vertices are collinear (zero radius)")
    axes = _axis_candidates(X)
    best = [_capsule_on_axis(pts, a, centre + _circle_centre(X, a)) for a in axes[np.argsort(_rough_volumes(X, axes))[:5]]]
    return min(best, key=_volume)


def _local_capsules(shape: RawShape) -> list[Capsule]:
    """Capsules of a shape in its own frame [mm]; ValueError/OSError when it cannot be read."""
    size = shape.size
    if shape.kind == "sphere":
        return [Capsule((0, 0, 0), (0, 0, 0), size[0])]
    if shape.kind == "capsule":
        h = size[1] / 2
        return [Capsule((0, 0, -h), (0, 0, h), size[0])]
    if shape.kind == "cylinder":
        return cylinder_capsule(size[0], size[1])
    if shape.kind == "box":
        return box_capsules(size)
    if shape.kind == "ellipsoid":
        return ellipsoid_capsule(size)
    if shape.kind == "mesh":
        return [mesh_capsule(shape.vertices())]
    raise ValueError(f"unsupported shape {shape.kind!r}")


def shape_capsules(shape: RawShape) -> list[Capsule]:
    """The capsules of ``shape`` in its link frame [mm] (see the module docstring)."""
    return [move_capsule(c, shape.T_link_shape) for c in _local_capsules(shape)]


# -- surface samples ------------------------------------------------------------------------
def _sphere_dirs(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (a Fibonacci sphere), (n, 3)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _capsule_points(radius: float, length: float, n: int) -> np.ndarray:
    d = _sphere_dirs(n) * radius
    h = length / 2
    shift = np.where(d[:, 2:3] >= 0, h, -h) * np.array([0.0, 0.0, 1.0])
    ring = _sphere_dirs(n)
    ring[:, 2] = 0.0
    ring = radius * ring / np.maximum(np.linalg.norm(ring, axis=1, keepdims=True), 1e-12)
    ring[:, 2] = np.linspace(-h, h, n)
    return np.concatenate([d + shift, ring])


def _box_points(size, n: int) -> np.ndarray:
    half = np.asarray(size, dtype=float) / 2
    m = max(2, int(round(math.sqrt(n / 6))))
    g = np.linspace(-1.0, 1.0, m)
    u, v = (a.ravel() for a in np.meshgrid(g, g))
    out = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.zeros((u.size, 3))
            others = [k for k in range(3) if k != axis]
            p[:, axis] = sign
            p[:, others[0]], p[:, others[1]] = u, v
            out.append(p * half)
    return np.concatenate(out)


def _local_points(shape: RawShape, n: int) -> np.ndarray:
    size = shape.size
    if shape.kind == "sphere":
        return _sphere_dirs(n) * size[0]
    if shape.kind == "capsule":
        return _capsule_points(size[0], size[1], n)
    if shape.kind == "cylinder":
        side = _capsule_points(size[0], size[1], n)[n:]
        disc = _sphere_dirs(n) * size[0]
        disc[:, 2] = np.where(disc[:, 2] >= 0, size[1] / 2, -size[1] / 2)
        return np.concatenate([side, disc])
    if shape.kind == "box":
        return _box_points(size, n)
    if shape.kind == "ellipsoid":
        return _sphere_dirs(n) * np.asarray(size, dtype=float)
    if shape.kind == "mesh":
        return np.unique(np.asarray(shape.vertices(), dtype=float), axis=0)
    raise ValueError(f"unsupported shape {shape.kind!r}")


def surface_points(shape: RawShape, n: int = 400) -> np.ndarray:
    """Points on the surface of ``shape`` in its link frame [mm], (m, 3): a mesh's vertices,
    about ``n`` (to a few times ``n``) evenly spread points of a primitive."""
    p = _local_points(shape, n)
    T = shape.T_link_shape
    return p @ T[:3, :3].T + T[:3, 3]


# -- mesh files -----------------------------------------------------------------------------
def read_mesh_vertices(path) -> np.ndarray:
    """The distinct vertices ``(n, 3)`` of the triangles of a mesh file, in the file's units
    (sorted, each once): what a link's capsule must hold and its fingertip is fitted to.

    Read by :func:`prehension.objects.mesh_io.read_triangles`, the package's one mesh reader
    (OBJ, STL, PLY, OFF, GLB, GLTF; DAE with pycollada); a scene is flattened with its node
    transforms applied.  Vertices no triangle uses are not part of the surface and are left
    out; so are the copies a format makes of a vertex (an OBJ's texture seams, an STL's
    corners listed per triangle), so that the result depends on the surface only.

    Raises:
        InvalidObject: (a ``ValueError``) the file is missing, unreadable, of a format not
            read, or holds no triangles; the message names the file and the formats read.
    """
    vertices, faces = read_triangles(Path(path))
    return np.unique(vertices[faces.ravel()], axis=0)
