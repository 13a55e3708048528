"""A proposed contact point grown into a patch fitted on the mesh.

:class:`MeshSurface` holds what every fit on one mesh shares, built once: the mesh's
:class:`~prehension.objects.distance.MeshDistance`, its face normals and its outer
surface (:func:`~prehension.objects.pick.outer_surface`: the faces a small step along the
normal leaves the solid through).  :meth:`MeshSurface.grow` fits a degree-2 Bézier patch
within the radius of the point with :func:`~prehension.objects.pick.region_from_mesh`,
exactly as ``prehension region --at P --radius R`` does (it refuses a patch whose normal
points into the object).  A fit that fails or strays from the mesh more than
``tolerance_mm`` is tried at half the radius, then replaced by a point region with the
sampled point's normal.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ..errors import PrehensionError
from ..geometry.regions import PointRegion, Region
from ..objects.meshes import Mesh
from ..objects.pick import OuterSurface, outer_surface, region_from_mesh

__all__ = ["MeshSurface", "CLEAR_MM"]

CLEAR_MM = 1.0  # a point region's outward step: twice the objects' default surface tolerance, as their check takes it


class MeshSurface:
    """One closed mesh [mm] prepared for many fits (see the module docstring)."""

    def __init__(self, mesh: Mesh, distance=None):
        if distance is None:
            from ..objects.distance import MeshDistance

            distance = MeshDistance(mesh.vertices, mesh.faces)
        self.mesh, self.distance = mesh, distance

    @cached_property
    def outer(self) -> OuterSurface:
        """The mesh's outer faces and the distance to them (built once)."""
        return outer_surface(self.mesh, self.distance)

    def grow(self, point, normal, radius: float, tolerance_mm: float) -> Region | None:
        """The region grown at surface ``point`` with outward ``normal`` (see the module
        docstring); ``None`` when even a point region cannot be placed there (a step of
        :data:`CLEAR_MM` along its normal stays inside the solid: the object's own check
        of its regions would refuse it)."""
        for r in (radius, 0.5 * radius):
            try:
                picked = region_from_mesh(self.mesh, at=point, radius=r, degree=2, distance=self.distance, outer=self.outer)
            except PrehensionError:
                continue
            if picked.max_deviation_mm <= tolerance_mm:
                return picked.region
        point, normal = np.asarray(point, float), np.asarray(normal, float)
        if self.distance.signed_distance((point + CLEAR_MM * normal)[None])[0] <= 0:
            return None
        return PointRegion(point, normal)
