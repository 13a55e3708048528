"""An object's checked mesh and distance tree, kept on disk between processes.

Reading a mesh file goes through trimesh (its import alone costs ~0.25 s, and it pulls in
scipy.optimize and scipy.ndimage), checks the surface (watertight, wound outwards) and
builds the distance tree of :class:`~prehension.objects.distance.MeshDistance`.  For a
command such as ``prehension solve teapot-lid-lifting`` that is a third of its start-up,
spent again in every process on the same file.  So the result -- the cleaned mesh and the
tree's flat arrays, nothing derived from them later -- is stored once in a ``.npz`` file
(plain arrays, read with ``allow_pickle=False``) and read back bit for bit by later
processes.

The entry's name is a SHA-256 of everything the result depends on: the solid (a mesh
file's *bytes* and scale; the primitives' exact values), whether it must be closed, the
source of the modules that check and build it, and the versions of trimesh, manifold3d
and numpy.  Editing the file, the scale, the code or a library therefore misses the cache
instead of returning a stale answer; a solid that fails its checks is never stored (the
error is raised again next time).

Where, and what happens when the folder cannot be written or an entry cannot be read:
:mod:`prehension.disk_cache` (shared with the hands' fitted capsules).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from ..disk_cache import CACHE_ENV, cache_folder, code_fingerprint, load_arrays, store_arrays
from .distance import MeshArrays, MeshDistance
from .meshes import Mesh

__all__ = ["CACHE_ENV", "cache_folder", "geometry_key", "load_geometry", "store_geometry"]

_SOURCES = ("mesh_io.py", "distance.py", "solid.py", "meshes.py", "geometry_cache.py")  # what builds an entry
_LIBRARIES = ("trimesh", "manifold3d", "numpy")


@functools.lru_cache(maxsize=1)
def _fingerprint() -> bytes:
    """The source of the modules that build an entry and the libraries' versions."""
    here = Path(__file__).parent
    return code_fingerprint([here / name for name in _SOURCES], _LIBRARIES)


def geometry_key(solid, closed: bool) -> str | None:
    """The entry name of ``(solid, closed)``: a hex SHA-256 of what the solid is made from
    (its ``content()``: a mesh file's scale and bytes, or the primitives' values); ``None``
    if it has none (an unreadable file: building it reports the problem)."""
    content = solid.content()
    if content is None:
        return None
    h = hashlib.sha256(_fingerprint())
    h.update(repr((type(solid).__name__, bool(closed))).encode())
    h.update(content)
    return h.hexdigest()


def load_geometry(key: str | None) -> tuple[Mesh, MeshDistance] | None:
    """The stored ``(Mesh, MeshDistance)`` of an entry; ``None`` if there is none (or it
    cannot be read whole)."""
    arrays = load_arrays(key, ("vertices", "faces", *MeshArrays._fields))
    if arrays is None:
        return None
    mesh, fields = Mesh(arrays[0], arrays[1]), arrays[2:]
    fields[-1] = bool(fields[-1])  # robust_sign: stored as a 0-d array
    distance = MeshDistance.__new__(MeshDistance)
    distance.__setstate__({"arrays": tuple(fields)})  # the pickling protocol: no tree rebuilt
    return mesh, distance


def store_geometry(key: str | None, mesh: Mesh, distance: MeshDistance) -> None:
    """Write an entry (atomically); silently nothing if the folder cannot be written."""
    store_arrays(key, dict(vertices=mesh.vertices, faces=mesh.faces, **dict(zip(MeshArrays._fields, distance.arrays))))
