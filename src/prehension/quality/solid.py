"""The object as a solid: what it is made of, where its centre is, how far it reaches.

:func:`object_solid` is the **one** place that reads an object's shape for physics and
for the torque scale of the quality measures, so that it adapts in one place when the
object model gains new kinds of shape.  A :class:`~prehension.objects.GraspObject`
offers, in this order of preference:

* its solid (``solid``, the shape the hand may not pass through): a union of primitives
  gives one convex piece per primitive (as display primitives below), a mesh file one
  piece, its closed surface as it is (convex or not);
* a display mesh file (``mesh_file``): one piece, the mesh as it is (convex or not);
* display primitives: one convex piece per primitive (the convex hull of its tessellation;
  a torus, the one primitive that is not convex, is cut into :data:`TORUS_SECTORS` convex
  sectors of its tube);
* nothing but contact regions: the convex hull of the regions (a box given by patches on
  two opposite faces becomes the slab between them).

Every piece is a closed triangle mesh in the object frame [mm].  Mass properties
(:func:`mass_properties`) are those of the union of the pieces with overlaps counted
twice, which is also how a physics engine weighs a body made of several geoms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..errors import InvalidObject
from ..frozen import cached_per_value
from ..geometry.regions import Region
from ..geometry.rotations import orthonormal_frame
from ..objects.meshes import Mesh, Torus
from ..objects.model import GraspObject
from ..objects.solid import PrimitiveSolid

__all__ = ["Solid", "MassProperties", "object_solid", "mass_properties", "object_reference", "hull_mesh", "TORUS_SECTORS", "object_center"]

TORUS_SECTORS = 16  # convex pieces of a torus (its tube's sagitta is 2% of the ring radius)
_REGION_SAMPLES = 9  # per parameter, when the solid is the hull of the regions


@dataclass(frozen=True, eq=False)
class Solid:
    """The object's solid: ``pieces`` (closed meshes, object frame, mm), which of them are
    convex, and where they came from (``"mesh file"``, ``"primitives"`` or ``"regions"``)."""

    pieces: tuple[Mesh, ...]
    convex: tuple[bool, ...]
    source: str

    def mesh(self) -> Mesh:
        """Every piece in one mesh."""
        return Mesh.concatenate(self.pieces)


@dataclass(frozen=True, eq=False)
class MassProperties:
    """Of a solid of unit density: ``volume_mm3``, ``centroid_mm (3,)`` and the inertia
    tensor about the centroid per unit density ``inertia_mm5 (3, 3)`` (mm^5), object frame."""

    volume_mm3: float
    centroid_mm: np.ndarray
    inertia_mm5: np.ndarray


@cached_per_value
def object_solid(obj: GraspObject) -> Solid:
    """The solid ``obj`` is (see the module docstring); computed once per object."""
    if isinstance(obj.solid, PrimitiveSolid):
        pieces = [piece for prim in obj.solid.primitives for piece in _primitive_pieces(prim)]
        return Solid(tuple(pieces), (True,) * len(pieces), "primitives")
    if obj.solid is not None:
        mesh = obj.surface
        return Solid((mesh,), (_is_convex(mesh),), "mesh file")
    if obj.mesh_file is not None:
        mesh = obj.display_mesh()
        if len(mesh.faces) == 0:
            raise InvalidObject(f"object {obj.name!r}: its mesh file {obj.mesh_file} has no triangles")
        return Solid((mesh,), (_is_convex(mesh),), "mesh file")
    if obj.primitives:
        pieces = [piece for prim in obj.primitives for piece in _primitive_pieces(prim)]
        return Solid(tuple(pieces), (True,) * len(pieces), "primitives")
    points = _region_points(obj)
    try:
        return Solid((hull_mesh(points),), (True,), "regions")
    except InvalidObject:
        raise InvalidObject(
            f"object {obj.name!r} has no solid shape: its regions span no volume and it has no primitives "
            "or mesh file; give it display primitives or a mesh (object.display in a task file)"
        ) from None


def _primitive_pieces(prim) -> list[Mesh]:
    if isinstance(prim, Torus):
        return _torus_sectors(prim)
    return [hull_mesh(prim.mesh().vertices)]


def _torus_sectors(torus: Torus, sectors: int = TORUS_SECTORS) -> list[Mesh]:
    """Convex hulls of ``sectors`` arcs of the torus's tube (each arc's two end circles and its middle one)."""
    centre = np.asarray(torus.center, float)
    e1, e2, axis = orthonormal_frame(np.asarray(torus.axis, float) / np.linalg.norm(torus.axis)).T
    phi = np.linspace(0, 2 * np.pi, max(torus.resolution // 2, 8), endpoint=False)
    pieces = []
    for k in range(sectors):
        angles = 2 * np.pi * (k + np.array([0.0, 0.5, 1.0])) / sectors
        radial = np.cos(angles)[:, None] * e1 + np.sin(angles)[:, None] * e2  # (3, 3) ring directions
        tube = np.cos(phi)[None, :, None] * radial[:, None, :] + np.sin(phi)[None, :, None] * axis  # (3, m, 3)
        points = centre + torus.major * radial[:, None, :] + torus.minor * tube
        pieces.append(hull_mesh(points.reshape(-1, 3)))
    return pieces


def _region_points(obj: GraspObject) -> np.ndarray:
    parts = [_samples(r) for r in obj.regions.values()]
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def _samples(region: Region) -> np.ndarray:
    """Points of ``region`` at a grid over its parameter box, those inside its domain (one
    point for a region without parameters)."""
    lo, hi = region.param_bounds()
    if not len(lo):
        return region.evaluate(np.zeros((1, 0)))[0]
    t = np.linspace(0.0, 1.0, _REGION_SAMPLES)
    grid = np.stack(np.meshgrid(*[lo[i] + t * (hi[i] - lo[i]) for i in range(len(lo))], indexing="ij"), -1).reshape(-1, len(lo))
    grid = grid[region.domain_violation(grid) <= 0.0]
    points, _ = region.evaluate(grid)
    return points


def hull_mesh(points) -> Mesh:
    """The convex hull of ``points (N, 3)`` [mm] as a closed, outward-oriented triangle mesh.

    Raises:
        InvalidObject: the points span no volume.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        raise InvalidObject(f"{len(pts)} points span no volume (they lie in a plane or a line)") from None
    used, faces = np.unique(hull.simplices, return_inverse=True)
    faces = faces.reshape(-1, 3)
    v = pts[used]
    normal = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    outward = np.einsum("fi,fi->f", normal, hull.equations[:, :3]) >= 0
    faces = np.where(outward[:, None], faces, faces[:, ::-1])
    return Mesh(v, faces)


def _is_convex(mesh: Mesh, tolerance: float = 0.005) -> bool:
    """The mesh fills its convex hull to within ``tolerance`` of the hull's volume."""
    try:
        hull = hull_mesh(mesh.vertices)
    except InvalidObject:
        return False
    own = abs(_volume_integrals(mesh)[0])
    whole = _volume_integrals(hull)[0]
    return bool(own >= (1.0 - tolerance) * whole)


def _volume_integrals(mesh: Mesh) -> tuple[float, np.ndarray, np.ndarray]:
    """``(volume, first moment (3,), second moment (3, 3))`` of a closed, consistently
    oriented mesh, by the divergence theorem over the tetrahedra (origin, triangle).

    .. math::

        V = \\sum \\det A / 6, \\qquad m_1 = \\sum \\det A\\,(a + b + c) / 24, \\qquad
        M_2 = \\sum \\det A\\; A\\, C\\, A^T, \\quad C = (1 + I) / 120,

    with ``A = [a b c]`` the triangle's vertices as columns (``C``: ones plus the identity).
    """
    tri = mesh.vertices[mesh.faces]  # (F, 3, 3): rows a, b, c
    det = np.einsum("fi,fi->f", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))  # (F,)
    volume = det.sum() / 6.0
    first = np.einsum("f,fi->i", det, tri.sum(axis=1)) / 24.0
    # A C A^T = (sum_k v_k v_k^T + s s^T) / 120 with v_k the vertices and s their sum
    s = tri.sum(axis=1)  # (F, 3)
    second = (np.einsum("f,fki,fkj->ij", det, tri, tri) + np.einsum("f,fi,fj->ij", det, s, s)) / 120.0
    return float(volume), first, second


def mass_properties(solid: Solid) -> MassProperties:
    """Volume, centroid and central inertia per unit density of ``solid``'s pieces.

    A piece whose faces are oriented inwards counts with its sign flipped (every piece is
    a closed solid).
    """
    volume, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
    for piece in solid.pieces:
        v, f, s = _volume_integrals(piece)
        sign = -1.0 if v < 0 else 1.0
        volume, first, second = volume + sign * v, first + sign * f, second + sign * s
    if not volume > 0:
        raise InvalidObject("the object's solid has no volume")
    centroid = first / volume
    second_c = second - volume * np.outer(centroid, centroid)  # about the centroid
    inertia = np.trace(second_c) * np.eye(3) - second_c
    return MassProperties(volume, centroid, inertia)


def object_reference(obj: GraspObject, center_mm=None) -> tuple[np.ndarray, float]:
    """``(centre (3,) [mm], radius [mm])`` of ``obj``, object frame.

    The centre is ``center_mm`` when given, else the centroid of the object's solid (its
    centre of mass at uniform density); the radius is the largest distance from the centre
    to the solid's surface, as GraspIt! scales torques.  An object with no solid (only
    points, or regions in a plane) uses its regions' sample points instead: their
    centroid, and their largest distance from the centre.

    Raises:
        InvalidObject: the radius would be zero (a single point and no solid).
    """
    try:
        solid = object_solid(obj)
    except InvalidObject:
        points = _region_points(obj)
        centre = (points.mean(axis=0) if len(points) else np.zeros(3)) if center_mm is None else np.asarray(center_mm, float)
        radius = float(np.max(np.linalg.norm(points - centre, axis=1))) if len(points) else 0.0
        if not radius > 0:
            raise InvalidObject(
                f"object {obj.name!r} has no size to scale torques by: give it a shape (display primitives "
                "or a mesh) or state the radius (QualityOptions(radius_mm=...))"
            ) from None
        return centre, radius
    centre = mass_properties(solid).centroid_mm if center_mm is None else np.asarray(center_mm, float)
    radius = float(max(np.max(np.linalg.norm(p.vertices - centre, axis=1)) for p in solid.pieces))
    return centre, radius


def object_center(obj: GraspObject) -> np.ndarray:
    """(3,) the centre :func:`object_reference` takes [mm]: the solid's centroid, else the
    centroid of the regions' sample points."""
    return _object_center(obj).copy()


@cached_per_value
def _object_center(obj: GraspObject) -> np.ndarray:
    try:
        return mass_properties(object_solid(obj)).centroid_mm
    except InvalidObject:
        points = _region_points(obj)
        return points.mean(axis=0) if len(points) else np.zeros(3)
