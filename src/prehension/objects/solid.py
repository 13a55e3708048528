"""An object's solid: the closed surface that collisions, region checks and the viewer use.

Two kinds, each a small frozen value that a task file can write back:

* :class:`MeshFileSolid`: a mesh file (OBJ, STL, PLY, OFF, GLB) and its scale (mm per
  file unit), read through :func:`~prehension.objects.mesh_io.load_mesh`.
* :class:`PrimitiveSolid`: closed primitives (boxes, spheres, ellipsoids, cylinders and
  frustums, tori; the same values as the display primitives of
  :mod:`prehension.objects.meshes`) united into one closed surface by a boolean union
  (manifold3d through trimesh).  The built-in objects are made this way.

Curved primitives are tessellated finely enough that the surface lies within
:data:`TESSELLATION_MM` of the exact shape (chord error), so a region fitted to the exact
shape agrees with the mesh.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InvalidObject
from ..geometry.rotations import orthonormal_frame
from .meshes import Box, Cylinder, Ellipsoid, Mesh, Sphere, Torus
from .mesh_io import checked_mesh, load_mesh

__all__ = ["MeshFileSolid", "PrimitiveSolid", "Solid", "TESSELLATION_MM", "primitive_solid_mesh", "solid_geometry"]

TESSELLATION_MM = 0.05  # largest chord error of a tessellated curved primitive [mm]


@dataclass(frozen=True)
class MeshFileSolid:
    """A closed mesh read from ``path`` (absolute), ``scale`` mm per file unit.

    ``units`` keeps the unit name the file gave (``"m"``...), for writing it back.
    """

    path: str
    scale: float
    units: str | None = None

    def mesh(self, closed: bool = True) -> Mesh:
        return load_mesh(self.path, self.scale, closed=closed)

    def content(self) -> bytes | None:
        """What the solid's mesh is made from: the scale and the file's bytes (``None``
        if the file cannot be read; building the mesh reports the problem)."""
        try:
            data = Path(self.path).read_bytes()
        except OSError:
            return None
        return repr(float(self.scale)).encode() + data

    def describe(self) -> str:
        return f"mesh file {self.path} (x{self.scale:g} mm per unit)"


@dataclass(frozen=True)
class PrimitiveSolid:
    """The union of closed primitives (object frame, mm)."""

    primitives: tuple

    def __post_init__(self):
        object.__setattr__(self, "primitives", tuple(self.primitives))
        if not self.primitives:
            raise InvalidObject("an object shape needs at least one primitive")

    def mesh(self, closed: bool = True) -> Mesh:
        return _union([primitive_solid_mesh(p) for p in self.primitives])

    def content(self) -> bytes:
        """What the solid's mesh is made from: the primitives' exact values (frozen
        dataclasses of floats: their repr is exact)."""
        return repr(self.primitives).encode()

    def describe(self) -> str:
        return f"union of {len(self.primitives)} primitives"


Solid = MeshFileSolid | PrimitiveSolid


def solid_geometry(solid: Solid, closed: bool = True):
    """``(Mesh, MeshDistance)`` of a solid, shared by every object made from the same
    solid (a mesh file is known by its path, size and modification time), and kept on
    disk between processes (:mod:`.geometry_cache`)."""
    key = (solid, closed)
    if isinstance(solid, MeshFileSolid):
        try:
            st = Path(solid.path).stat()
            key = (solid, closed, st.st_size, st.st_mtime_ns)
        except OSError:
            pass  # load_mesh reports the missing file
    return _cached_geometry(key)


@functools.lru_cache(maxsize=32)
def _cached_geometry(key):
    """Built once per process; across processes read from the disk cache of
    :mod:`.geometry_cache` (the same arrays, bit for bit) when an entry exists."""
    from .distance import MeshDistance
    from .geometry_cache import geometry_key, load_geometry, store_geometry

    solid, closed = key[0], key[1]
    disk_key = geometry_key(solid, closed)
    stored = load_geometry(disk_key)
    if stored is not None:
        return stored
    mesh = solid.mesh(closed=closed)
    distance = MeshDistance(mesh.vertices, mesh.faces)
    store_geometry(disk_key, mesh, distance)
    return mesh, distance


def _sections(radius: float, tol: float = TESSELLATION_MM) -> int:
    """Polygon sides so that a circle of ``radius`` has chord error <= ``tol``."""
    if radius <= tol:
        return 8
    return int(max(8, min(512, math.ceil(math.pi / math.acos(1.0 - tol / radius)))))


def _subdivisions(radius: float, tol: float = TESSELLATION_MM) -> int:
    """Icosphere subdivisions so that the sphere's chord error is <= ``tol``."""
    for k in range(1, 7):
        edge = 1.05 * radius / 2**k  # icosahedron edge ~1.05 r, halved at each level
        if edge**2 / (8 * radius) <= tol:
            return k
    return 7


def _align(start, end) -> np.ndarray:
    """A 4x4 transform taking +z to ``end - start`` and the origin to ``start``."""
    T = np.eye(4)
    axis = np.asarray(end, float) - np.asarray(start, float)
    T[:3, :3] = orthonormal_frame(axis / np.linalg.norm(axis))
    T[:3, 3] = start
    return T


def primitive_solid_mesh(prim):
    """A closed trimesh of one primitive (object frame, mm)."""
    import trimesh

    if isinstance(prim, Box):
        T = np.eye(4)
        T[:3, 3] = prim.center
        return trimesh.creation.box(extents=np.asarray(prim.size, float), transform=T)
    if isinstance(prim, (Sphere, Ellipsoid)):
        radii = np.full(3, float(prim.radius)) if isinstance(prim, Sphere) else np.asarray(prim.radii, float)
        m = trimesh.creation.icosphere(subdivisions=_subdivisions(float(radii.max())))
        m.vertices = m.vertices * radii + np.asarray(prim.center, float)
        return m
    if isinstance(prim, Cylinder):
        p0, p1 = np.asarray(prim.start, float), np.asarray(prim.end, float)
        h = float(np.linalg.norm(p1 - p0))
        if h < 1e-9:
            raise InvalidObject("cylinder start and end must differ")
        r0 = float(prim.radius)
        r1 = r0 if prim.end_radius is None else float(prim.end_radius)
        line = np.array([[0.0, 0.0], [r0, 0.0], [r1, h], [0.0, h]])
        return trimesh.creation.revolve(line, sections=_sections(max(r0, r1)), transform=_align(p0, p1))
    if isinstance(prim, Torus):
        axis = np.asarray(prim.axis, float)
        m = trimesh.creation.torus(
            prim.major, prim.minor, major_sections=_sections(prim.major + prim.minor),
            minor_sections=_sections(prim.minor), transform=_align(prim.center, np.asarray(prim.center, float) + axis),
        )  # fmt: skip
        return m
    raise InvalidObject(f"cannot make a solid of {type(prim).__name__}; shapes are boxes, spheres, ellipsoids, cylinders, tori")


def _union(parts) -> Mesh:
    import trimesh

    if len(parts) == 1:
        merged = parts[0]
    else:
        try:
            merged = trimesh.boolean.union(parts, engine="manifold")
        except ImportError:  # pragma: no cover - manifold3d is a dependency
            raise InvalidObject("uniting primitives needs manifold3d: pip install manifold3d") from None
    return checked_mesh(merged.vertices, merged.faces, "object shape (union of primitives)", closed=True)
