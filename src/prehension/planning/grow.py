"""A proposed contact point grown into a patch fitted on the mesh.

:class:`MeshSurface` holds what every fit on one mesh shares, built once: the mesh's
:class:`~prehension.objects.distance.MeshDistance`, its face normals and its outer
surface (:func:`~prehension.objects.pick.outer_surface`: the faces a small step along the
normal leaves the solid through).  :meth:`MeshSurface.grow` fits a degree-2 Bézier patch
within the radius of the point with :func:`~prehension.objects.pick.region_from_mesh`,
exactly as ``prehension region --at P --radius R`` does (it refuses a patch whose normal
points into the object).  A fit that fails or strays from the mesh more than
``tolerance_mm`` is tried at half the radius, then replaced by a point region with the
closest face's normal.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ..errors import PrehensionError
from ..geometry.regions import PointRegion, Region
from ..objects.meshes import Mesh
from ..objects.pick import OuterSurface, outer_surface, region_from_mesh

__all__ = ["MeshSurface"]


class MeshSurface:
    """One closed mesh [mm] prepared for many fits (see the module docstring)."""

    def __init__(self, mesh: Mesh, distance=None):
        if distance is None:
            from ..objects.distance import MeshDistance

            distance = MeshDistance(mesh.vertices, mesh.faces)
        self.mesh, self.distance = mesh, distance
        tri = mesh.vertices[mesh.faces]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        self.normals = cross / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)[:, None]

    @cached_property
    def outer(self) -> OuterSurface:
        """The mesh's outer faces and the distance to them (built once)."""
        return outer_surface(self.mesh, self.distance)

    def grow(self, point, radius: float, tolerance_mm: float) -> Region | None:
        """The region grown at surface ``point`` (see the module docstring); ``None`` when
        even a point region cannot be placed there (its normal would point inwards)."""
        for r in (radius, 0.5 * radius):
            try:
                picked = region_from_mesh(self.mesh, at=point, radius=r, degree=2, distance=self.distance, outer=self.outer)
            except PrehensionError:
                continue
            if picked.max_deviation_mm <= tolerance_mm:
                return picked.region
        seed = int(self.distance.closest_faces(np.asarray(point, float)[None])[0])
        if not self.outer.mask[seed]:
            return None
        return PointRegion(np.asarray(point, float), self.normals[seed])
