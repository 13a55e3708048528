"""A proposed contact point grown into a patch fitted on the mesh.

:class:`MeshSurface` holds what every fit on one mesh shares, built once: the mesh's
:class:`~prehension.objects.distance.MeshDistance`, its face normals and centres, which
faces are *outer* (a step of :data:`~prehension.objects.pick.OUTSIDE_STEP_MM` along the
normal from the face's centre leaves the solid) and the faces' edge adjacency.
:meth:`MeshSurface.grow` picks the piece around a point (the outer faces within the radius
whose normals lie within 60 deg of the closest face's, connected to it) and fits a degree-2
Bézier patch to those faces with :func:`~prehension.objects.pick.region_from_mesh` (the fit
``prehension region`` makes; it refuses a patch whose normal points into the object).  A
fit that fails or strays from the mesh more than ``tolerance_mm`` is tried at half the
radius, then replaced by a point region with the face's normal.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ..errors import PrehensionError
from ..geometry.regions import PointRegion, Region
from ..objects.meshes import Mesh
from ..objects.pick import OUTSIDE_STEP_MM, region_from_mesh

__all__ = ["MeshSurface"]

_PIECE_COS = 0.5  # faces of a piece: normals within 60 deg of the seed face's


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
        self.centres = tri.mean(axis=1)
        self.triangles = tri

    @cached_property
    def outer(self) -> np.ndarray:
        """(F,) bool: faces a small step along the normal from their centre leaves the solid through."""
        return self.distance.signed_distance(self.centres + OUTSIDE_STEP_MM * self.normals) > 0

    @cached_property
    def _neighbours(self) -> list[np.ndarray]:
        faces = self.mesh.faces
        edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        owner = np.tile(np.arange(len(faces)), 3)
        _, key = np.unique(edges, axis=0, return_inverse=True)
        order = np.argsort(key.ravel(), kind="stable")
        k, o = key.ravel()[order], owner[order]
        same = k[:-1] == k[1:]
        a, b = o[:-1][same], o[1:][same]
        pairs = np.concatenate([np.stack([a, b], 1), np.stack([b, a], 1)])
        pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
        return np.split(pairs[:, 1], np.searchsorted(pairs[:, 0], np.arange(1, len(faces))))

    def piece(self, point, radius: float) -> tuple[int, np.ndarray]:
        """``(closest face, faces of the piece)`` around ``point`` within ``radius`` [mm]."""
        seed = int(self.distance.closest_faces(np.asarray(point, float)[None])[0])
        reach = np.linalg.norm(self.triangles - np.asarray(point, float), axis=2).min(axis=1)
        ok = (reach <= radius) & self.outer & (self.normals @ self.normals[seed] >= _PIECE_COS)
        ok[seed] = True
        seen, todo = {seed}, [seed]
        while todo:
            for f in self._neighbours[todo.pop()]:
                if ok[f] and f not in seen:
                    seen.add(int(f))
                    todo.append(int(f))
        return seed, np.array(sorted(seen))

    def grow(self, point, radius: float, tolerance_mm: float) -> Region | None:
        """The region grown at surface ``point`` (see the module docstring); ``None`` when
        even a point region cannot be placed there (its normal would point inwards)."""
        for r in (radius, 0.5 * radius):
            seed, faces = self.piece(point, r)
            try:
                picked = region_from_mesh(self.mesh, faces=faces, degree=2, distance=self.distance)
            except PrehensionError:
                continue
            if picked.max_deviation_mm <= tolerance_mm and np.linalg.norm(picked.point - point) <= r:
                return picked.region
        seed = int(self.distance.closest_faces(np.asarray(point, float)[None])[0])
        if not self.outer[seed]:
            return None
        return PointRegion(np.asarray(point, float), self.normals[seed])
