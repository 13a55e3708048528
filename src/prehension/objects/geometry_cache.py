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

Other arrays derived from a mesh alone -- the physics test's convex decomposition
(:mod:`prehension.sim.pieces`) -- share the folder: :func:`content_key` names such an
entry by a hash of everything it is computed from, :func:`store_arrays` and
:func:`load_arrays` write and read it.

Where: ``$PREHENSION_CACHE_DIR`` if set (``off``, ``0`` or an empty value: no cache), else
``$XDG_CACHE_HOME/prehension/geometry`` (``~/.cache/prehension/geometry``).  A folder that
cannot be written, or an entry that cannot be read, only costs the rebuild: the cache is
never needed for a correct answer.  Entries are written atomically
(:mod:`prehension.atomic`), so concurrent processes never read half a file.
"""

from __future__ import annotations

import functools
import hashlib
import io
import os
from importlib import metadata
from pathlib import Path

import numpy as np

from ..atomic import write_bytes_atomic
from .distance import MeshArrays, MeshDistance
from .meshes import Mesh

__all__ = ["CACHE_ENV", "cache_folder", "geometry_key", "load_geometry", "store_geometry", "content_key", "load_arrays",
           "store_arrays"]

CACHE_ENV = "PREHENSION_CACHE_DIR"
_OFF = ("", "0", "off", "none", "false")
_SOURCES = ("mesh_io.py", "distance.py", "solid.py", "meshes.py", "geometry_cache.py")  # what builds an entry
_LIBRARIES = ("trimesh", "manifold3d", "numpy")


def cache_folder() -> Path | None:
    """The folder of the entries, or ``None`` when the cache is switched off."""
    value = os.environ.get(CACHE_ENV)
    if value is not None:
        return None if value.strip().lower() in _OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = Path.home() / ".cache"
        except RuntimeError:  # no home folder known: no cache
            return None
    return Path(base) / "prehension" / "geometry"


@functools.lru_cache(maxsize=1)
def _fingerprint() -> bytes:
    """The source of the modules that build an entry and the libraries' versions."""
    h = hashlib.sha256()
    here = Path(__file__).parent
    for name in _SOURCES:
        h.update((here / name).read_bytes())
    for lib in _LIBRARIES:
        try:
            h.update(f"{lib}={metadata.version(lib)};".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{lib}=absent;".encode())
    return h.digest()


def geometry_key(solid, closed: bool) -> str | None:
    """The entry name of ``(solid, closed)``: a hex SHA-256; ``None`` if it has none
    (an unreadable file: building it reports the problem)."""
    from .solid import MeshFileSolid, PrimitiveSolid

    h = hashlib.sha256(_fingerprint())
    h.update(repr((type(solid).__name__, bool(closed))).encode())
    if isinstance(solid, MeshFileSolid):
        try:
            data = Path(solid.path).read_bytes()
        except OSError:
            return None
        h.update(repr(float(solid.scale)).encode())
        h.update(data)
    elif isinstance(solid, PrimitiveSolid):
        h.update(repr(solid.primitives).encode())  # frozen dataclasses of floats: repr is exact
    else:
        return None
    return h.hexdigest()


def _entry(key: str | None) -> Path | None:
    folder = cache_folder()
    return None if (folder is None or key is None) else folder / f"{key}.npz"


def load_geometry(key: str | None) -> tuple[Mesh, MeshDistance] | None:
    """The stored ``(Mesh, MeshDistance)`` of an entry; ``None`` if there is none (or it
    cannot be read whole)."""
    data = load_arrays(key, ("vertices", "faces") + MeshArrays._fields)
    if data is None:
        return None
    mesh = Mesh(data["vertices"], data["faces"])
    fields = [data[name] for name in MeshArrays._fields]
    fields[-1] = bool(fields[-1])  # robust_sign: stored as a 0-d array
    distance = MeshDistance.__new__(MeshDistance)
    distance.__setstate__({"arrays": tuple(fields)})  # the pickling protocol: no tree rebuilt
    return mesh, distance


def store_geometry(key: str | None, mesh: Mesh, distance: MeshDistance) -> None:
    """Write an entry (atomically); silently nothing if the folder cannot be written."""
    store_arrays(key, vertices=mesh.vertices, faces=mesh.faces, **dict(zip(MeshArrays._fields, distance.arrays)))


def content_key(*parts) -> str:
    """A hex SHA-256 of ``parts`` (bytes as they are, arrays by dtype, shape and bytes,
    anything else by its ``repr``): the entry name of something derived from them only."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            part = repr((part.dtype.str, part.shape)).encode() + np.ascontiguousarray(part).tobytes()
        elif not isinstance(part, bytes):
            part = repr(part).encode()
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def load_arrays(key: str | None, names) -> dict[str, np.ndarray] | None:
    """The arrays ``names`` of an entry; ``None`` if there is none (or it cannot be read whole)."""
    path = _entry(key)
    if path is None or not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in names}
    except Exception:  # noqa: BLE001 - a damaged entry (cut short, not a zip, a missing array, ...)
        return None  # rebuilt (and rewritten) by the caller: the cache is never needed for a correct answer


def store_arrays(key: str | None, **arrays) -> None:
    """Write an entry of named arrays (atomically); silently nothing if the folder cannot be written."""
    path = _entry(key)
    if path is None:
        return
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, buffer.getvalue())
    except OSError:
        pass  # a read-only home, a full disk: the next process builds it again
