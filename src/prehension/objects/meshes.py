"""Display meshes built from simple primitives (object frame, mm).

A mesh is only for looking at a grasp: the solvers never read it.  Each primitive is a
small frozen value that can be written to and read from a task file; ``to_mesh`` turns a
list of them into one triangle mesh.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InvalidObject
from ..geometry.rotations import orthonormal_frame

__all__ = ["Mesh", "Box", "Sphere", "Ellipsoid", "Cylinder", "Torus", "Primitive", "to_mesh", "read_off"]


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh: ``vertices (V, 3)`` [mm] and ``faces (F, 3)`` vertex indices."""

    vertices: np.ndarray
    faces: np.ndarray

    def __post_init__(self):
        v = np.asarray(self.vertices, dtype=float).reshape(-1, 3)
        f = np.asarray(self.faces, dtype=int).reshape(-1, 3)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise InvalidObject(f"mesh faces index vertices 0..{len(v) - 1}, got indices {f.min()}..{f.max()}")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)

    def transformed(self, T) -> "Mesh":
        T = np.asarray(T, dtype=float)
        return Mesh(self.vertices @ T[:3, :3].T + T[:3, 3], self.faces)

    @staticmethod
    def concatenate(meshes) -> "Mesh":
        verts, faces, n = [], [], 0
        for m in meshes:
            verts.append(m.vertices)
            faces.append(m.faces + n)
            n += len(m.vertices)
        if not verts:
            return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
        return Mesh(np.concatenate(verts), np.concatenate(faces))


def _grid_mesh(points: np.ndarray, wrap_u: bool, wrap_v: bool) -> Mesh:
    """Triangulate a (nu, nv, 3) grid of points, optionally closed in u and/or v."""
    nu, nv = points.shape[:2]
    idx = np.arange(nu * nv).reshape(nu, nv)
    iu = np.arange(nu if wrap_u else nu - 1)
    iv = np.arange(nv if wrap_v else nv - 1)
    a = idx[iu[:, None], iv[None, :]]
    b = idx[(iu[:, None] + 1) % nu, iv[None, :]]
    c = idx[(iu[:, None] + 1) % nu, (iv[None, :] + 1) % nv]
    d = idx[iu[:, None], (iv[None, :] + 1) % nv]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return Mesh(points.reshape(-1, 3), faces)


def _positive(value, what) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise InvalidObject(f"{what} must be a positive number of mm, got {value}")
    return value


@dataclass(frozen=True)
class Box:
    """Axis-aligned box (object frame): centre and full sizes [mm]."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]

    def mesh(self) -> Mesh:
        c, s = np.asarray(self.center, float), np.asarray(self.size, float) / 2
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * s + c
        quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        faces = [tri for a, b, c_, d in quads for tri in ((a, b, c_), (a, c_, d))]
        return Mesh(corners, np.array(faces))


@dataclass(frozen=True)
class Ellipsoid:
    """Ellipsoid with axis-aligned semi-axes [mm]."""

    center: tuple[float, float, float]
    radii: tuple[float, float, float]
    resolution: int = 24

    def mesh(self) -> Mesh:
        n = self.resolution
        th = np.linspace(1e-3, np.pi - 1e-3, n)
        ph = np.linspace(0, 2 * np.pi, 2 * n, endpoint=False)
        T, P = np.meshgrid(th, ph, indexing="ij")
        unit = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
        return _grid_mesh(unit * np.asarray(self.radii, float) + np.asarray(self.center, float), False, True)


@dataclass(frozen=True)
class Sphere:
    center: tuple[float, float, float]
    radius: float

    def mesh(self) -> Mesh:
        r = _positive(self.radius, "sphere radius")
        return Ellipsoid(self.center, (r, r, r)).mesh()


@dataclass(frozen=True)
class Cylinder:
    """Cylinder or frustum from ``start`` to ``end`` with radii at each end [mm]."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float
    end_radius: float | None = None
    resolution: int = 32

    def mesh(self) -> Mesh:
        p0, p1 = np.asarray(self.start, float), np.asarray(self.end, float)
        if np.linalg.norm(p1 - p0) < 1e-9:
            raise InvalidObject("cylinder start and end must differ")
        r0 = _positive(self.radius, "cylinder radius")
        r1 = r0 if self.end_radius is None else _positive(self.end_radius, "cylinder end_radius")
        e1, e2, _ = orthonormal_frame((p1 - p0) / np.linalg.norm(p1 - p0)).T
        ang = np.linspace(0, 2 * np.pi, self.resolution, endpoint=False)
        ring = np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2
        grid = np.stack([p0 + r0 * ring, p1 + r1 * ring], axis=1)  # (n, 2, 3)
        side = _grid_mesh(grid, True, False)
        caps = Mesh.concatenate([_fan(p0, p0 + r0 * ring[::-1]), _fan(p1, p1 + r1 * ring)])
        return Mesh.concatenate([side, caps])


def _fan(centre, rim) -> Mesh:
    n = len(rim)
    faces = np.stack([np.zeros(n, int), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n], -1)
    return Mesh(np.vstack([centre, rim]), faces)


@dataclass(frozen=True)
class Torus:
    """Torus about ``axis`` through ``center``: ring radius ``major``, tube ``minor`` [mm]."""

    center: tuple[float, float, float]
    axis: tuple[float, float, float]
    major: float
    minor: float
    resolution: int = 32

    def mesh(self) -> Mesh:
        R, r = _positive(self.major, "torus major radius"), _positive(self.minor, "torus minor radius")
        axis = np.asarray(self.axis, float)
        e1, e2, z = orthonormal_frame(axis / np.linalg.norm(axis)).T
        u = np.linspace(0, 2 * np.pi, self.resolution, endpoint=False)
        v = np.linspace(0, 2 * np.pi, self.resolution // 2, endpoint=False)
        U, V = np.meshgrid(u, v, indexing="ij")
        radial = np.cos(U)[..., None] * e1 + np.sin(U)[..., None] * e2
        pts = (R + r * np.cos(V))[..., None] * radial + (r * np.sin(V))[..., None] * z
        return _grid_mesh(pts + np.asarray(self.center, float), True, True)


Primitive = Box | Sphere | Ellipsoid | Cylinder | Torus


def to_mesh(primitives) -> Mesh:
    """One triangle mesh from a list of primitives."""
    return Mesh.concatenate([p.mesh() for p in primitives])


def read_off(path) -> Mesh:
    """Read a triangle/polygon mesh in OFF format (polygons are fan-triangulated)."""
    path = Path(path)
    try:
        tokens = [ln.split("#", 1)[0] for ln in path.read_text().splitlines()]
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidObject(f"cannot read mesh file {path}: {exc}") from None
    words = " ".join(tokens).split()
    if not words or not words[0].upper().endswith("OFF"):
        raise InvalidObject(f"{path}: not an OFF mesh (it must start with 'OFF')")
    try:
        nv, nf = int(words[1]), int(words[2])
        nums = words[4:]
        verts = np.array(nums[: 3 * nv], float).reshape(nv, 3)
        faces, k = [], 3 * nv
        for _ in range(nf):
            n = int(nums[k])
            poly = [int(x) for x in nums[k + 1 : k + 1 + n]]
            faces += [(poly[0], poly[i], poly[i + 1]) for i in range(1, n - 1)]
            k += 1 + n
    except (IndexError, ValueError):
        raise InvalidObject(f"{path}: malformed OFF mesh (counts do not match the data)") from None
    return Mesh(verts, np.array(faces, dtype=int).reshape(-1, 3))
