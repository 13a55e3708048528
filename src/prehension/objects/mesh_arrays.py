"""A closed triangle mesh as the flat arrays every compiled distance query reads.

:class:`MeshArrays` holds the triangles of a closed, outward-oriented mesh in the order of a
bounding-volume hierarchy (axis-aligned boxes, median split) with, per triangle, the
pseudonormals of its face, edges and corners (Bærentzen & Aanæs, IEEE TVCG 11(3), 2005),
which sign a point's distance.  Built once per mesh (:func:`build_mesh_arrays`); queried by
:mod:`.point_distance` and :mod:`.segment_distance`.  Lengths in mm.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["MeshArrays", "SdGrid", "build_mesh_arrays", "empty_mesh_arrays", "LEAF_SIZE", "STACK_DEPTH"]

LEAF_SIZE = 8
STACK_DEPTH = 128  # traversal stack depth: enough for trees of up to 2^60 leaves


class MeshArrays(NamedTuple):
    """The flat arrays every distance kernel reads (a numba-friendly bundle).

    Triangles are stored in tree order, so that leaf ``k`` holds the triangles
    ``node_start[k] : node_start[k] + node_count[k]``.

    Attributes:
        tri: (F, 3, 3) triangle corners [mm], ``tri[f, i]`` the i-th corner.
        face_normal: (F, 3) unit outward face normals.
        edge_normal: (F, 3, 3) pseudonormal of edge ``i`` (corners ``i`` and ``i + 1``):
            the normalised sum of the normals of the two faces that share it.
        vertex_normal: (F, 3, 3) angle-weighted pseudonormal of corner ``i``.
        node_lo, node_hi: (N, 3) box corners of each tree node [mm].
        node_left, node_right: (N,) children (-1 for a leaf).
        node_start, node_count: (N,) a leaf's triangle range.
        face_id: (F,) index of each stored triangle in the original mesh.
        robust_sign: inside/outside by the winding number (a mesh of several pieces)
            instead of the pseudonormal test.
    """

    tri: np.ndarray
    face_normal: np.ndarray
    edge_normal: np.ndarray
    vertex_normal: np.ndarray
    node_lo: np.ndarray
    node_hi: np.ndarray
    node_left: np.ndarray
    node_right: np.ndarray
    node_start: np.ndarray
    node_count: np.ndarray
    face_id: np.ndarray
    robust_sign: bool


def _unit_rows(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _pseudonormals(vertices: np.ndarray, faces: np.ndarray):
    """Face normals (F, 3), edge pseudonormals (F, 3, 3), vertex pseudonormals (F, 3, 3)."""
    tri = vertices[faces]  # (F, 3, 3)
    n_face = _unit_rows(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    # vertex: sum over faces of (incident angle) * face normal
    angles = np.empty(faces.shape)
    for i in range(3):
        e1 = _unit_rows(tri[:, (i + 1) % 3] - tri[:, i])
        e2 = _unit_rows(tri[:, (i + 2) % 3] - tri[:, i])
        angles[:, i] = np.arccos(np.clip(np.sum(e1 * e2, axis=1), -1.0, 1.0))
    acc = np.zeros_like(vertices)
    for i in range(3):
        np.add.at(acc, faces[:, i], angles[:, i, None] * n_face)
    n_vertex = _unit_rows(acc)[faces]  # (F, 3, 3)
    # edge i = (corner i, corner i+1): the sum of the normals of the faces sharing it
    a, b = faces, np.roll(faces, -1, axis=1)
    key = np.minimum(a, b).astype(np.int64) * (len(vertices) + 1) + np.maximum(a, b)  # (F, 3)
    _, inverse = np.unique(key.ravel(), return_inverse=True)
    edge_sum = np.zeros((inverse.max() + 1, 3))
    np.add.at(edge_sum, inverse, np.repeat(n_face, 3, axis=0))
    n_edge = _unit_rows(edge_sum[inverse]).reshape(-1, 3, 3)
    return n_face, n_edge, n_vertex


def _build_tree(centroids: np.ndarray, lo_f: np.ndarray, hi_f: np.ndarray):
    """Median-split tree over faces: node arrays and the face order (leaves contiguous)."""
    order = np.arange(len(centroids))
    nodes = []  # [lo, hi, left, right, start, count]
    todo = [(0, len(order), -1, 0)]  # (start, end, parent, side)
    while todo:
        s, e, parent, side = todo.pop()
        idx = order[s:e]
        k = len(nodes)
        nodes.append([lo_f[idx].min(axis=0), hi_f[idx].max(axis=0), -1, -1, s, e - s])
        if parent >= 0:
            nodes[parent][2 + side] = k
        if e - s <= LEAF_SIZE:
            continue
        c = centroids[idx]
        axis = int(np.argmax(np.ptp(c, axis=0)))
        order[s:e] = idx[np.argsort(c[:, axis], kind="stable")]
        m = (s + e) // 2
        nodes[k][4], nodes[k][5] = s, 0
        todo += [(m, e, k, 1), (s, m, k, 0)]
    arr = lambda j, dt=float: np.array([n[j] for n in nodes], dtype=dt)  # noqa: E731
    return arr(0), arr(1), arr(2, np.int64), arr(3, np.int64), arr(4, np.int64), arr(5, np.int64), order


def _pieces(n_vertices: int, faces: np.ndarray) -> int:
    """Number of connected pieces of a mesh (faces joined through shared vertices)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(np.arange(len(faces)), 3)
    graph = sp.coo_matrix((np.ones(rows.size), (rows, faces.ravel())), shape=(len(faces), n_vertices)).tocsr()
    used = np.unique(faces)
    n, _ = connected_components((graph.T @ graph)[used][:, used], directed=False)
    return int(n)


def build_mesh_arrays(vertices, faces) -> MeshArrays:
    """The :class:`MeshArrays` of a closed, outward-oriented mesh ``vertices (V, 3)`` [mm], ``faces (F, 3)``."""
    v = np.ascontiguousarray(vertices, dtype=float)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    robust = _pieces(len(v), f) > 1
    n_face, n_edge, n_vertex = _pseudonormals(v, f)
    tri = v[f]
    lo, hi, left, right, start, count, order = _build_tree(tri.mean(axis=1), tri.min(axis=1), tri.max(axis=1))
    c = np.ascontiguousarray
    return MeshArrays(
        c(tri[order]), c(n_face[order]), c(n_edge[order]), c(n_vertex[order]),
        lo, hi, left, right, start, count, order.astype(np.int64), bool(robust),
    )  # fmt: skip


def empty_mesh_arrays() -> MeshArrays:
    """A :class:`MeshArrays` with no triangle (the same numba type as any other): what a
    compiled caller receives when there is no solid; it must not be queried."""
    z = lambda *shape: np.zeros(shape)  # noqa: E731
    i = lambda: np.zeros(0, dtype=np.int64)  # noqa: E731
    return MeshArrays(z(0, 3, 3), z(0, 3), z(0, 3, 3), z(0, 3, 3), z(0, 3), z(0, 3), i(), i(), i(), i(), i(), False)


class SdGrid(NamedTuple):
    """The mesh's signed distance at the nodes of a regular grid, each node computed
    (exactly, :func:`.point_distance.signed_distance_at`) the first time it is read and kept: an approximate,
    cheap signed distance (trilinear, error up to about the spacing near edges and corners)
    for the local kernel's *seeing* rows, which only steer the iterations; every verdict
    still comes from the exact queries.  A node's value depends only on the mesh, so the
    order in which nodes are filled changes no answer.

    Filled and read by the local solver (:mod:`prehension.solvers.local._sd_grid`); the
    type itself is the mesh's, beside :class:`MeshArrays` and importable from
    :mod:`prehension.objects.distance`, where numba's on-disk caches written before the
    grid moved look it up (a cache index naming a class that no longer exists fails to
    load instead of being rebuilt).

    Attributes:
        lo: (3,) position of node (0, 0, 0), object frame [mm].
        h: spacing [mm].
        val: (nx, ny, nz) float32 signed distance at node ``lo + h (i, j, k)`` [mm], NaN until read.
    """

    lo: np.ndarray
    h: float
    val: np.ndarray
