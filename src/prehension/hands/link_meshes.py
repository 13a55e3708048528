"""The triangles of a link's mesh files (:class:`~prehension.hands.model.LinkMesh`), read
when a link is drawn.

A hand keeps only references to the files that draw its links (path, pose, scale): they
travel with it to worker processes for free and are read by nothing that checks or solves.
Drawing reads them through :func:`~prehension.objects.mesh_io.read_triangles` (any format
trimesh reads, a scene flattened with its node transforms applied), each file once per
process while it is unchanged (an in-memory cache keyed by the path, the file's size and
modification time).
"""

from __future__ import annotations

import functools
import os

import numpy as np

from ..objects.mesh_io import read_triangles
from .model import LinkMesh

__all__ = ["link_mesh_triangles", "joined_link_triangles"]


@functools.lru_cache(maxsize=128)
def _file_triangles(path: str, size: int, mtime_ns: int) -> tuple[np.ndarray, np.ndarray]:
    del size, mtime_ns  # the key: a file changed on disk is read again
    vertices, faces = read_triangles(path)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


def link_mesh_triangles(mesh: LinkMesh) -> tuple[np.ndarray, np.ndarray]:
    """``mesh``'s triangles in its link's frame: vertices ``(V, 3)`` [mm] and faces ``(F, 3)``.

    Raises:
        InvalidObject: (a ``ValueError``) the file is missing, unreadable or holds no
            triangles; the message names the file.
    """
    try:
        stat = os.stat(mesh.path)
        vertices, faces = _file_triangles(mesh.path, stat.st_size, stat.st_mtime_ns)
    except OSError:  # gone: read_triangles says so, naming the file
        vertices, faces = read_triangles(mesh.path)
    T = mesh.T_link_mesh
    return (vertices * np.asarray(mesh.scale)) @ T[:3, :3].T + T[:3, 3], faces


def joined_link_triangles(meshes) -> tuple[np.ndarray, np.ndarray] | None:
    """The triangles of all of a link's ``meshes`` (:class:`LinkMesh` files) in its frame,
    joined: vertices ``(V, 3)`` [mm] and faces ``(F, 3)``; ``None`` when one of them cannot
    be read (a picture or scene then draws the link's capsules instead)."""
    vertices, faces, offset = [], [], 0
    try:
        for mesh in meshes:
            v, f = link_mesh_triangles(mesh)
            vertices.append(v)
            faces.append(np.asarray(f) + offset)
            offset += len(v)
    except ValueError:  # InvalidObject: the file is gone or unreadable
        return None
    if not vertices:
        return None
    return np.concatenate(vertices), np.concatenate(faces)
