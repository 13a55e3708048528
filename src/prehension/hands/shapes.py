"""Shapes of hand files -> collision capsules, and surface points for fingertip fits.

Capsules stay *inside* the shapes they stand for, so that self-collision checks do not
report contacts the real shapes do not make (all in the shape's own frame, mm):

- sphere: the sphere itself (a capsule with ``a == b``);
- capsule: itself;
- cylinder (along z): the largest capsule about the axis that fits inside, radius
  ``min(r, L/2)``, segment half-length ``L/2 - radius`` (a flat disc becomes the
  inscribed sphere);
- box with sides ``long >= mid >= short``: ``n = ceil(mid/short)`` (at most 8) parallel
  capsules of radius ``short/2`` along the long side (half-length ``long/2 - short/2``),
  spread evenly across the mid side; their union lies inside the box and fills it but for
  its rounded edges (and gaps in plates thinner than ``mid/8``);
- ellipsoid: a capsule along its long axis that stays inside (:func:`ellipsoid_capsule`);
- mesh: one capsule along the principal axis (PCA) of the vertices, radius the 90th
  percentile of the vertices' distances to that axis, segment shortened by the radius at
  each end of the vertices' extent.  An approximation meant for self-collision checks.

:func:`surface_points` samples the surface of any shape (the vertices of a mesh), for
the fingertip fits of :mod:`prehension.hands.fingertips`.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

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


def cylinder_capsule(radius: float, length: float) -> list[Capsule]:
    rho = min(radius, length / 2)
    h = length / 2 - rho
    return [Capsule((0, 0, -h), (0, 0, h), rho)]


def box_capsules(size) -> list[Capsule]:
    size = np.asarray(size, dtype=float)
    if not np.all(size > 0):
        raise ValueError(f"box sizes must be positive, got {size.tolist()} mm")
    long_ax, mid_ax, short_ax = np.argsort(-size, kind="stable")
    rho = float(size[short_ax]) / 2
    h = float(size[long_ax]) / 2 - rho
    n = min(_MAX_BOX_CAPSULES, max(1, math.ceil(size[mid_ax] / size[short_ax] - 1e-9)))
    w = float(size[mid_ax]) / 2 - rho
    offsets = np.linspace(-w, w, n) if n > 1 else np.zeros(1)
    e_long, e_mid = np.eye(3)[long_ax], np.eye(3)[mid_ax]
    return [Capsule(s * e_mid - h * e_long, s * e_mid + h * e_long, rho) for s in offsets]


def ellipsoid_capsule(semi_axes) -> list[Capsule]:
    """A capsule inside the ellipsoid with semi-axes ``a >= m >= c``, along the long axis.

    A ball of radius ``rho`` centred at ``x0`` on the long axis lies inside when
    ``rho <= c sqrt(1 - x0^2 / D)``, ``D = a^2 - c^2``, for ``|x0| <= D / a`` (the nearest
    boundary point lies in the plane of the long and the short axes).  We take the
    half-length ``h = min(D / a, 0.6 sqrt(D))`` and ``rho = c sqrt(1 - h^2 / D)`` (>= 0.8 c);
    a sphere (``D = 0``) stays itself.
    """
    s = np.asarray(semi_axes, dtype=float)
    if not np.all(s > 0):
        raise ValueError(f"ellipsoid semi-axes must be positive, got {s.tolist()} mm")
    long_ax, _, short_ax = np.argsort(-s, kind="stable")
    a, c = float(s[long_ax]), float(s[short_ax])
    D = a * a - c * c
    if D <= 1e-12 * a * a:
        return [Capsule((0, 0, 0), (0, 0, 0), c)]
    h = min(D / a, 0.6 * math.sqrt(D))
    e = np.eye(3)[long_ax]
    return [Capsule(-h * e, h * e, c * math.sqrt(1.0 - h * h / D))]


def mesh_capsule(points) -> Capsule:
    """A capsule along the principal axis of ``points (n, 3)``: radius = 90th percentile of
    the distances to the axis, ends pulled in by the radius from the points' extent."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    if len(pts) < 2:
        raise ValueError("the mesh has fewer than 2 distinct vertices")
    centre = pts.mean(axis=0)
    X = pts - centre
    axis = np.linalg.svd(X, full_matrices=False)[2][0]
    t = X @ axis
    rho = float(np.percentile(np.linalg.norm(X - t[:, None] * axis, axis=1), 90))
    if not rho > 0:
        raise ValueError("the mesh vertices are collinear (zero radius)")
    lo, hi = t.min() + rho, t.max() - rho
    if lo > hi:
        lo = hi = (t.min() + t.max()) / 2
    return Capsule(centre + lo * axis, centre + hi * axis, rho)


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
def _obj_vertices(text: str) -> np.ndarray:
    rows = [line.split()[1:4] for line in text.splitlines() if line.startswith("v ")]
    return np.array(rows, dtype=float).reshape(-1, 3)


def _stl_vertices(data: bytes) -> np.ndarray:
    if len(data) >= 84:
        n = int.from_bytes(data[80:84], "little")
        if len(data) == 84 + 50 * n:  # binary STL
            tri = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dtype=tri, count=n, offset=84)["v"].reshape(-1, 3).astype(float)
    number = r"([-+0-9.eE]+)"
    rows = re.findall(rf"vertex\s+{number}\s+{number}\s+{number}", data.decode("ascii", errors="replace"))
    return np.array(rows, dtype=float).reshape(-1, 3)


def read_mesh_vertices(path) -> np.ndarray:
    """Vertices ``(n, 3)`` of an ``.obj`` (``v`` lines) or ``.stl`` (ascii or binary) mesh,
    in the file's units.  Raises ``OSError``/``ValueError`` if it cannot be read."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".obj":
        pts = _obj_vertices(path.read_text(errors="replace"))
    elif suffix == ".stl":
        pts = _stl_vertices(path.read_bytes())
    else:
        raise ValueError(f"unsupported mesh format {suffix!r} (only .obj and .stl are read)")
    if len(pts) == 0 or not np.all(np.isfinite(pts)):
        raise ValueError("no finite vertices found")
    return pts
