"""Exact distances to a closed triangle mesh: points (signed) and segments (unsigned).

:class:`MeshDistance` holds a bounding-volume hierarchy (axis-aligned boxes, median split)
over the triangles of a closed, outward-oriented mesh, as flat arrays that numba's
kernels read (:class:`~.mesh_arrays.MeshArrays`).  Distances are exact up to rounding, not
sampled:

* :meth:`MeshDistance.signed_distance`: the distance from each point to the surface,
  negative inside (:mod:`.point_distance`).  The sign comes from the angle-weighted
  pseudonormal of the closest feature (face, edge or vertex), which is exact for a closed,
  consistently oriented mesh of one piece (Bærentzen & Aanæs, IEEE TVCG 11(3), 2005); for
  a mesh of several closed pieces (parts glued face to face, which leaves internal double
  walls) from the generalised winding number, exact for any closed pieces however they touch.
* :meth:`MeshDistance.segment_distance`: the distance from each segment to the surface
  (0 when the segment crosses it), the minimum over triangles of the closed-form
  segment-triangle distance (Ericson, *Real-Time Collision Detection*, 5.1.5 and 5.1.9;
  :mod:`.segment_distance`); :meth:`MeshDistance.closest_pair` also returns the closest
  pair (a point of the segment, a point of the surface), and
  :meth:`MeshDistance.capsule_depth` how deep capsules reach into the solid.

Both prune with a lower bound per box, so a query visits ``O(log F)`` triangles when the
surface is far from most of them.  All lengths are in the mesh's units (mm in prehension).

The modules: :mod:`.mesh_arrays` (the mesh as flat arrays, built once), :mod:`.point_distance`
and :mod:`.segment_distance` (the compiled queries), this one (the friendly wrapper).  The
local solver's lazily filled grid of the signed distance lives with the local solver
(:mod:`prehension.solvers.local._sd_grid`).
"""

from __future__ import annotations

import numpy as np

from ..kernels.aot import aot
from ..kernels.jit import njit
from .mesh_arrays import MeshArrays, SdGrid, build_mesh_arrays, empty_mesh_arrays
from .point_distance import point_query, signed_distances
from .segment_distance import REL_TOL, capsule_depths, segment_closest, segment_closest_within, segment_distances, segment_min_sd

__all__ = [
    "MeshArrays", "MeshDistance", "SdGrid", "build_mesh_arrays", "empty_mesh_arrays", "segment_closest", "segment_closest_within",
    "segment_min_sd", "capsule_depths", "signed_distances", "REL_TOL",
]  # fmt: skip


class MeshDistance:
    """Distances to one closed, outward-oriented triangle mesh (see the module docstring).

    Args:
        vertices: (V, 3) [mm].
        faces: (F, 3) vertex indices, counter-clockwise seen from outside.
    """

    def __init__(self, vertices, faces):
        self.arrays = build_mesh_arrays(vertices, faces)

    def __getstate__(self):
        return {"arrays": tuple(self.arrays)}

    def __setstate__(self, state):
        self.arrays = MeshArrays(*state["arrays"])

    @property
    def face_normals(self) -> np.ndarray:
        """(F, 3) unit outward normals in the original face order."""
        out = np.empty_like(self.arrays.face_normal)
        out[self.arrays.face_id] = self.arrays.face_normal
        return out

    def signed_distance(self, points, *, closest: bool = False):
        """``points (N, 3) -> (N,)`` [mm], negative inside; with ``closest=True`` also the
        closest surface points (N, 3)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        q = np.empty_like(p)
        d = aot(signed_distances)(self.arrays, p, q)
        return (d, q) if closest else d

    def segment_distance(self, starts, ends) -> np.ndarray:
        """Unsigned distance of segments ``starts (N, 3)``-``ends (N, 3)`` to the surface (N,) [mm]."""
        a = np.ascontiguousarray(np.asarray(starts, dtype=float).reshape(-1, 3))
        b = np.ascontiguousarray(np.asarray(ends, dtype=float).reshape(-1, 3))
        return segment_distances(self.arrays, a, b)

    def closest_pair(self, start, end):
        """``(distance [mm], point on the segment (3,), point on the surface (3,))`` of one
        segment ``start (3,)``-``end (3,)``; the points are ``None`` when the segment meets
        the surface (distance 0)."""
        a = np.ascontiguousarray(np.asarray(start, dtype=float).reshape(3))
        b = np.ascontiguousarray(np.asarray(end, dtype=float).reshape(3))
        ps, pm = np.empty(3), np.empty(3)
        d = float(segment_closest(self.arrays, a, b, ps, pm))
        return (d, ps, pm) if d > 0.0 else (0.0, None, None)

    def capsule_depth(self, starts, ends, radius, step: float = 0.25, cap: float = np.inf) -> np.ndarray:
        """Penetration depth of capsules ``starts (N, 3)``-``ends (N, 3)``, ``radius (N,)`` [mm], (N,) [mm];
        with ``cap`` [mm], depths above it may be returned as any value above it (see
        :func:`capsule_depths`: much cheaper for a yes/no test)."""
        a = np.ascontiguousarray(np.asarray(starts, dtype=float).reshape(-1, 3))
        b = np.ascontiguousarray(np.asarray(ends, dtype=float).reshape(-1, 3))
        r = np.array(radius, dtype=float).reshape(-1)  # a writable copy: one compiled signature for every caller
        return aot(capsule_depths)(self.arrays, a, b, r, float(step), float(cap))

    def closest_faces(self, points) -> np.ndarray:
        """Index (in the original mesh) of the face closest to each point, (N,)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 3))
        return self.arrays.face_id[_closest_face_ids(self.arrays, p)]


@njit(cache=True)
def _closest_face_ids(m, points):
    out = np.empty(points.shape[0], np.int64)
    q = np.empty(3)
    for i in range(points.shape[0]):
        out[i] = point_query(m, points[i], q)[1]
    return out
